"""The grasp as a value (:class:`~grasptask.grasp.grasp.Grasp`) and the settings every judge of it reads."""
