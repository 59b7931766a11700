"""Declarative pipelines: stages of grasptask commands, skipped when their inputs and config are unchanged."""
