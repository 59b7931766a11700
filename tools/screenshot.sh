#!/usr/bin/env bash
# The README's pictures of the report (docs/report_top.png, docs/report_view.png), made anew from the current
# demo: runs the demo pipeline (its unchanged stages are skipped), then opens the report in headless Chromium
# and saves its top and its first interactive grasp view.
# Usage: tools/screenshot.sh [VENV_BIN]   (make screenshot passes .venv/bin)
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-.venv/bin}
"$BIN/grasptask" pipeline run pipelines/demo.yaml
"$BIN/grasptask" report --results results/demo --out results/demo/report --check-browser --screenshot docs/report_top.png \
    --view-screenshot docs/report_view.png
echo "wrote docs/report_top.png, docs/report_view.png"
