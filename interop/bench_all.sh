#!/usr/bin/env bash
# The speed comparisons with OpenCV behind the README's speed tables (remap and maps,
# `stereocal rectify` on a bag, calibration, ChArUco, PnP, decoding, stereo matching),
# in one run: the release builds they time, then each side-by-side script in turn with
# the arguments the README gives for it, its wall time after it. A script that fails
# stops the run with its status. Run it on a machine with nothing else running (the
# scripts alternate the two sides in rounds, so a change of load weighs on both, but
# all-thread figures need the cores free) and compare ratios, not times.
#
# Usage: interop/bench_all.sh [LOG]   (LOG, default target/bench_all.log, gets a copy of the output)
set -euo pipefail
log=$(realpath -m "${1:-$(dirname "$0")/../target/bench_all.log}")
cd "$(dirname "$0")/.."
mkdir -p "$(dirname "$log")"
py=.venv/bin/python

{
  echo "stereocal $(git describe --always --dirty 2>/dev/null || echo unknown), $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cpus"
  cargo build --release --bin stereocal --bin decode_timing -p stereocal
  cargo build --release -p stereocal-vision --example remap_image --example detect_target \
    --example calib_timing --example pnp_timing --example stereo_timing

  run() {
    echo
    echo "== $*"
    local start=$SECONDS
    "$@"
    echo "(took $((SECONDS - start)) s; load average $(cut -d' ' -f1-3 /proc/loadavg))"
  }
  run $py interop/bench_remap_opencv.py --bin target/release/examples/remap_image \
    --iterations 60 --rounds 5
  run $py interop/bench_rectify_bag_opencv.py --rounds 3
  run $py interop/bench_calibrate_opencv.py --repeats 7
  run $py interop/bench_charuco_opencv.py --rounds 5 --repeats 5
  run $py interop/bench_pnp_opencv.py --rounds 3
  run $py interop/bench_decode_opencv.py
  run $py interop/bench_depth_opencv.py
} 2>&1 | tee "$log"
