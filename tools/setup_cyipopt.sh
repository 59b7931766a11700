#!/usr/bin/env bash
# Build cyipopt against the IPOPT that CasADi's wheel already ships (library and headers), so the second
# backend needs nothing but pip: no system IPOPT, no manual step. Usage: tools/setup_cyipopt.sh .venv/bin/python
set -euo pipefail
python=${1:-python3}
casadi_dir=$("$python" -c 'import casadi, os; print(os.path.dirname(casadi.__file__))')
pc_dir=$(mktemp -d)
trap 'rm -rf "$pc_dir"' EXIT
version=$(sed -n 's/^Version: //p' "$casadi_dir/pkgconfig/ipopt.pc")
cat > "$pc_dir/ipopt.pc" <<PC
libdir=$casadi_dir
includedir=$casadi_dir/include/coin-or
Name: Ipopt
Description: Interior Point Optimizer (bundled with CasADi)
Version: $version
Cflags: -I\${includedir}
Libs: -L\${libdir} -lipopt
PC
PKG_CONFIG_PATH="$pc_dir" LDFLAGS="-Wl,-rpath,$casadi_dir" "$python" -m pip install --quiet --no-cache-dir cyipopt
"$python" -c 'import cyipopt; print("cyipopt", cyipopt.__version__, "built against the IPOPT bundled with CasADi")'
