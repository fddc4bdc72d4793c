#!/bin/bash
# Device run 3: this stop's binary against the last one (interleaved), the whole integration suite
# with validation required, and the path-tracer race with the new default.
exec > >(tee -a $OUT/log3.txt) 2>&1
stamp() { echo "=== [${SECONDS} s] $*"; }
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
mkdir -p /work; [ -e /work/main ] || ln -s "$PWD" /work/main
mkdir -p target/release; cp .dev/vkrad target/release/vkrad
V=$PWD/.dev/vkrad; O=$PWD/.dev/vkrad-old
$V devices | head -1
TIMEFORMAT='wall %R s'
cd /tmp
stamp "interleaved: new, old"
for i in 1 2 3; do
  for b in new:$V old:$O; do t=${b%%:*}; B=${b#*:}
    echo "-- rfield $t $i"; time $B rfield -q --size 256x256 -o /tmp/rfield-$t.exr --report /tmp/r-$t-$i.json
    echo "-- cornell800 $t $i"; time $B cornell -q -o /tmp/cornell-$t.png --report /tmp/c-$t-$i.json
  done
done
python3 - <<'PY'
import json,glob
for f in sorted(glob.glob('/tmp/[rc]-*-*.json')):
    r=json.load(open(f)); w=r['timing']['wall_s']
    print(f.split('/')[-1], {k: round(v,3) for k,v in w.items()}, 'direct', r.get('direct_light'))
PY
echo "-- rfield new --profile"; $V rfield --size 256x256 -o /tmp/p.exr --profile 2>&1 | tail -40
cp /tmp/rfield-new.exr $OUT/
cd - >/dev/null
stamp "integration tests, validation required"
VKRAD_REQUIRE_VALIDATION=1 timeout 240 .dev/it > /tmp/it.txt 2>&1; echo "it rc=$?"
grep -E "FAILED|test result|panicked" /tmp/it.txt | head -30
grep -A25 "^failures:" /tmp/it.txt | grep -v "static TLS" | head -60
cp /tmp/it.txt $OUT/it-tests3.txt
stamp "race, new default"
mkdir -p /tmp/site && tar xJf .dev/mitsuba-slim.tar.xz -C /tmp/site && export PYTHONPATH=/tmp/site
cd bench/pathtracer
timeout 120 python3 compare.py --scene rfield --vkrad $V --size 256x256 --ref-spp 4096 --converge default --variant cuda_ad_rgb --target 0.02 --max-spp 2048 --out /tmp/race 2>&1 | grep -E "pt |vkrad|to "
cp /tmp/race/race-rfield.json $OUT/race-rfield3.json; cp /tmp/race/race-rfield.png $OUT/race-rfield3.png
stamp done
