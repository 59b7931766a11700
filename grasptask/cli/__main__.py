"""``python -m grasptask.cli``: the same as the ``grasptask`` command."""

from grasptask.cli import main

main()
