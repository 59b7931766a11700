"""A grasp in the forms it leaves the pipeline in: meshes of the hand, object and contacts (for the report's views
and figures and for the export), GLB scenes and JSON records other tools load."""
