#!/bin/bash
# Device run 2: the integration tests one at a time (find the crash), then the path-tracer race on the GPU.
exec > >(tee -a $OUT/log2.txt) 2>&1
stamp() { echo "=== [${SECONDS} s] $*"; }
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
mkdir -p /work; [ -e /work/main ] || ln -s "$PWD" /work/main
mkdir -p target/release; cp .dev/vkrad target/release/vkrad
V=$PWD/.dev/vkrad
$V devices | head -1
ls /usr/local/nvidia/lib64 2>/dev/null | grep -i -E "optix|libcuda.so" | head
stamp "tests one at a time, validation required"
SKIP="--skip ctrl_c_stops_cleanly --skip beyond_the_device_limits"
for round in 1 2 3 4; do
  VKRAD_REQUIRE_VALIDATION=1 timeout 200 .dev/it --test-threads 1 $SKIP > /tmp/t$round.txt 2>&1; rc=$?
  grep -E "FAILED|test result" /tmp/t$round.txt | head -20
  cp /tmp/t$round.txt $OUT/it-round$round.txt 2>/dev/null
  [ $rc = 139 ] || [ $rc = 134 ] || break
  last=$(grep -E "^test " /tmp/t$round.txt | tail -1 | sed 's/^test \([^ ]*\) .*/\1/')
  stamp "round $round crashed (rc $rc) in $last; alone without validation:"
  timeout 60 .dev/it --test-threads 1 --exact "$last" 2>&1 | tail -5
  SKIP="$SKIP --skip $last"
  [ $SECONDS -gt 260 ] && break
done
grep -A30 "^failures:" /tmp/t$round.txt | head -60
stamp "path tracer on the GPU"
mkdir -p /tmp/site && tar xJf .dev/mitsuba-slim.tar.xz -C /tmp/site && export PYTHONPATH=/tmp/site
python3 -c "import mitsuba as mi, drjit as dr; mi.set_variant('cuda_ad_rgb'); x=dr.arange(mi.Float,8)*2; dr.eval(x); print('cuda ok', mi.__version__)" || exit 0
cd bench/pathtracer
timeout 170 python3 compare.py --scene rfield --vkrad $V --size 256x256 --ref-spp 4096 --converge default --variant cuda_ad_rgb --target 0.02 --max-spp 4096 --out /tmp/race 2>&1 | tail -25
cp /tmp/race/race-rfield.json /tmp/race/race-rfield.png $OUT/ 2>/dev/null
stamp "cornell race"
timeout 110 python3 compare.py --scene cornell --vkrad $V --size 256x256 --ref-spp 65536 --converge default --variant cuda_ad_rgb --target 0.015 --max-spp 8192 --out /tmp/race 2>&1 | tail -15
cp /tmp/race/race-cornell.json /tmp/race/race-cornell.png $OUT/ 2>/dev/null
stamp done
