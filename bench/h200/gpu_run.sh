#!/bin/bash
# One prepared device run: loaders, device pick, timed renders, GPU ray bench, tests, scaling corpus.
L=$OUT/log.txt
exec > >(tee -a $L) 2>&1

stamp() { echo "=== [${SECONDS} s] $*"; }
stamp setup
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
ldconfig -p | grep -c libvulkan
nvidia-smi -L; nproc
mkdir -p /work; [ -e /work/main ] || ln -s "$PWD" /work/main
mkdir -p target/release; cp .dev/vkrad target/release/vkrad
V=$PWD/.dev/vkrad
$V devices | tee /tmp/dev.txt
if ! grep -qi nvidia /tmp/dev.txt; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  stamp "no NVIDIA device by default; VK_DRIVER_FILES set"; $V devices | tee /tmp/dev.txt
fi
grep -qi nvidia /tmp/dev.txt || { ls /usr/local/nvidia/share/vulkan/icd.d/ /usr/local/nvidia/lib* 2>&1 | head; cat /usr/local/nvidia/share/vulkan/icd.d/*.json; VK_LOADER_DEBUG=error,driver $V devices 2>&1 | tail -20; exit 1; }
TIMEFORMAT='wall %R s'
stamp "renders (interleaved)"
cd /tmp
for i in 1 2 3; do
  echo "-- cornell 800x800 run $i"; time $V cornell -q -o /tmp/cornell.png --report /tmp/c$i.json
  echo "-- rfield 256 default run $i"; time $V rfield -q --size 256x256 -o /tmp/rfield.exr --report /tmp/r$i.json
  echo "-- rfield 256 --direct-light cpu run $i"; time $V rfield -q --size 256x256 --direct-light cpu -o /tmp/rfield-cpu.exr --report /tmp/rc$i.json
done
echo "-- rfield 256 --validate"; time $V rfield -q --size 256x256 --validate -o /tmp/rfield-val.exr
echo "-- cornell 800 --validate"; time $V cornell -q --validate -o /tmp/cornell-val.png
python3 - <<'PY' > $OUT/reports.json
import json,glob
print(json.dumps({f: json.load(open(f)) for f in sorted(glob.glob('/tmp/*.json')) if f.split('/')[-1][0] in 'cr'}))
PY
cp /tmp/rfield.exr /tmp/rfield-cpu.exr /tmp/cornell.png $OUT/
cd - >/dev/null
stamp "gpu_rays bench"
timeout 90 .dev/gpu_rays --repeats 3
stamp "tests, validation required"
VKRAD_REQUIRE_VALIDATION=1 timeout 100 .dev/libtests --test-threads 8 2>&1 | grep -E "^test .*FAILED|panicked|test result|^failures" | head -40
VKRAD_REQUIRE_VALIDATION=1 timeout 200 .dev/it --test-threads 8 > $OUT/it-tests.txt 2>&1; echo "it rc=$?"
grep -E "^test .*FAILED|test result|^failures:" $OUT/it-tests.txt | head -40
stamp "scaling corpus (--large)"
PYTHONUNBUFFERED=1 timeout 150 python3 bench/memory.py --large --vkrad $V --out $OUT/memory-h200.json
stamp done
