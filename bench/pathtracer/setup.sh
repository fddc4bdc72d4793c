#!/usr/bin/env bash
# Idempotent setup for the Mitsuba 3 reference / race (compare.py).
# - installs mitsuba (+ numpy, matplotlib) from PyPI for python3
# - fetches Debian 12's libllvm19 (bookworm main, 1:19.1.7-3~deb12u1) with
#   `apt-get download`, unpacks it locally (no system install) into ./llvm,
#   so Dr.Jit's LLVM backend (variant llvm_ad_rgb) can load it through
#   DRJIT_LIBLLVM_PATH. Its dependencies (libedit2 libffi8 libxml2 libz3-4
#   libzstd1 zlib1g) were already installed on this machine; they are
#   installed here with apt-get if missing.
# Usage: bash setup.sh   then   source env.sh   (compare.py also finds ./llvm by itself)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE"

python3 -c 'import mitsuba, numpy, matplotlib' 2>/dev/null || \
  python3 -m pip install --quiet mitsuba numpy matplotlib

SO="$HERE/llvm/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if [ ! -f "$SO" ]; then
  if ! apt-cache show libllvm19 >/dev/null 2>&1; then
    apt-get update
  fi
  if ! apt-cache show libllvm19 >/dev/null 2>&1; then
    # not in bookworm main on an older mirror snapshot: try backports
    echo 'deb http://deb.debian.org/debian bookworm-backports main' \
      > /etc/apt/sources.list.d/bookworm-backports.list
    apt-get update
  fi
  missing=""
  for p in libedit2 libffi8 libxml2 libz3-4 libzstd1 zlib1g; do
    dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
  done
  [ -z "$missing" ] || apt-get install -y $missing
  mkdir -p debs
  ls debs/libllvm19_*.deb >/dev/null 2>&1 || (cd debs && apt-get download libllvm19)
  dpkg -x debs/libllvm19_*.deb llvm
fi

cat > env.sh <<EOT
export DRJIT_LIBLLVM_PATH="$SO"
EOT

DRJIT_LIBLLVM_PATH="$SO" python3 - <<'PY'
import mitsuba as mi
mi.set_variant('llvm_ad_rgb')
import drjit as dr
assert dr.all(dr.arange(mi.Float, 4) * 2 == mi.Float([0, 2, 4, 6]))
print('setup ok: mitsuba', mi.__version__, 'variant llvm_ad_rgb works')
PY
