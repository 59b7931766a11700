"""Unit names accepted in manifests and tool configs, as factors to SI."""

from __future__ import annotations

FORCE_UNITS = {"N": 1.0, "mN": 1e-3, "kN": 1e3}
TORQUE_UNITS = {"N.m": 1.0, "N.cm": 1e-2, "N.mm": 1e-3}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
UNIT_TABLES = {"force_unit": FORCE_UNITS, "torque_unit": TORQUE_UNITS, "time_unit": TIME_UNITS}

#: torques in the paper's tables are printed in N.cm
PAPER_TORQUE_UNIT = "N.cm"
