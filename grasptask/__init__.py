"""grasptask: task-oriented grasps for a multi-fingered hand, from sensorized-tool demonstrations."""

__version__ = "0.1.0"
