"""The grasp as a value (:class:`~grasptask.grasp.grasp_pose.Grasp`) and the settings every judge of it reads."""
