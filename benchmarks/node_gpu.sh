#!/usr/bin/env bash
# benchmarks/node.py on an offline GPU node (issue 32), from the checkout root, with .gpu/ beside it: made by
# `bash ../shared/gpu/prepare.sh .gpu` on a machine with package access (wheels for the node's Python 3.12 and
# the EGL/GL libraries; .gpu/ is git-ignored, so carry it to the node with the checkout). Installs them (as
# ../shared/gpu/README.md says), checks that EGL renders on the GPU, then runs node.py into OUT (default
# docs/results/<date>_gpu), which node.py rewrites after each row: a run cut short by NODE_TIMEOUT
# (seconds, default 540) keeps what it measured. Every step has a time limit; the first failing one stops it.
#   bash benchmarks/node_gpu.sh [OUT] [node.py options, e.g. --rows render gen decision --seconds-per-row 10]
# Inside a 15-minute device lease, whose $OUT returns at most 8 files (node.md, node.json and up to 9 profiles): the
# compiled rows first, their cold compiles side by side (--warm), then the other rows on the warm machine, e.g.
#   NODE_TIMEOUT=500 bash benchmarks/node_gpu.sh /tmp/node --rows train decision --compile on \
#     --compile-mode default reduce-overhead --warm 240 --seconds-per-row 5; tar czf "$OUT/node.tgz" -C /tmp node
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/results/$(date -u +%F)_gpu}
[ $# -gt 0 ] && shift
if [ ! -d .gpu/wheels ]; then
  echo "node_gpu.sh: no .gpu/wheels in $(pwd): run 'bash ../shared/gpu/prepare.sh .gpu' where packages can be downloaded" >&2
  exit 2
fi
step() { echo "[node_gpu] $1" >&2; shift; "$@"; }
if [ "$(id -u)" = 0 ] && ls .gpu/debs/*.deb >/dev/null 2>&1; then
  step "EGL/GL libraries from .gpu/debs" bash -c 'for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig'
fi
step "wheels from .gpu/wheels" timeout 180 python3 -m pip install -q --no-index --no-deps .gpu/wheels/*.whl
step "RVN, editable" timeout 180 python3 -m pip install -q --no-deps --no-build-isolation -e .
step "EGL on the GPU" timeout 60 python3 -c \
  "import moderngl; print(moderngl.create_standalone_context(backend='egl').info['GL_RENDERER'])"
step "GPU" timeout 30 nvidia-smi --query-gpu=name,memory.used,memory.total,utilization.gpu --format=csv,noheader || true
step "benchmarks/node.py --out $out $*" timeout "${NODE_TIMEOUT:-540}" python3 benchmarks/node.py --out "$out" "$@"
