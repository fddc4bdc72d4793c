#!/bin/bash
# Device run 6 (prepared in stop 39, not yet run: no GPU lent since stop 36).
# What it answers: on a real GPU, are the final gather's ray passes
# (--ray-device: camera and hemisphere rays; --direct-light: the lights'
# rays) faster than the CPU's 16 cores, so that auto's choice (the GPU on
# any GPU) is right; and do the GPU tests pass there.
#
# Prepare here (this machine), then one `run` with carry [".gl", ".dev"]
# and timeout_s 480:
#   echo /.gl/ >>.git/info/exclude; echo /.dev/ >>.git/info/exclude
#   mkdir -p .gl /tmp/amd64/partial; o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
#   apt-get $o update; (cd .gl && apt-get $o download libvulkan1 vulkan-validationlayers)
#   cargo build --release && cargo test --release --no-run --test it
#   mkdir -p .dev && cp target/release/vkrad .dev/ && cp "$(ls -t target/release/deps/it-* | grep -v '\.d$' | head -1)" .dev/it
#   strip .dev/vkrad .dev/it
# command: bash bench/h200/gpu_run6.sh
# It ran in 58 s here on lavapipe (2 cores, with GPU=lavapipe, which
# skips the driver checks); its log and reports come back under $OUT.
exec > >(tee -a "$OUT/log6.txt") 2>&1
stamp() { echo "=== [${SECONDS} s] $*"; }
stamp setup
if [ "${GPU:-nvidia}" = nvidia ]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
  nvidia-smi -L; nproc
fi
mkdir -p /work; [ -e /work/main ] || ln -s "$PWD" /work/main
V=$PWD/.dev/vkrad
$V devices | tee /tmp/dev.txt
if [ "${GPU:-nvidia}" = nvidia ] && ! grep -qi nvidia /tmp/dev.txt; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  stamp "no NVIDIA device by default; VK_DRIVER_FILES set"; $V devices | tee /tmp/dev.txt
  grep -qi nvidia /tmp/dev.txt || exit 1
fi
RF="rfield --size 256x256 --eye=28.0,28.0,69.0 --look-at=28.0,0.0,17.5 --up=0.0,1.0,0.0 --fov=50.0"
TIMEFORMAT='wall %R s'
stamp "whole commands, interleaved: rays and lights on the GPU (auto), rays on the CPU, both on the CPU"
cd /tmp
for i in 1 2 3; do
  for mode in auto:"" raycpu:"--ray-device cpu" cpu:"--ray-device cpu --direct-light cpu"; do
    tag=${mode%%:*}; args=${mode#*:}
    echo "-- rfield $tag $i"; time $V $RF -q $args -o /tmp/rf-$tag.exr --report /tmp/r-$tag-$i.json --trace /tmp/t-rf-$tag-$i.json
    echo "-- cornell $tag $i"; time $V cornell -q --size 256x256 $args -o /tmp/co-$tag.exr --report /tmp/c-$tag-$i.json --trace /tmp/t-co-$tag-$i.json
  done
done
echo "-- rfield --validate"; time $V $RF -q --validate -o /tmp/rf-val.exr
python3 - <<'PY' | tee "$OUT/stages6.txt"
import glob, json, collections, statistics
def spans(f):
    ev = json.load(open(f)); ev = ev["traceEvents"] if isinstance(ev, dict) else ev
    out = collections.defaultdict(float)
    for e in ev:
        if e.get("ph") == "X" and e.get("cat") == "step" or e.get("name") in ("gather", "solve"):
            out[e["name"]] = out[e["name"]] + e["dur"] / 1e6
    return out
for scene in ("rf", "co"):
    for tag in ("auto", "raycpu", "cpu"):
        runs = [spans(f) for f in sorted(glob.glob(f"/tmp/t-{scene}-{tag}-*.json"))]
        keys = sorted(set().union(*runs), key=lambda k: -runs[0].get(k, 0))
        print(scene, tag, {k: round(statistics.median(r.get(k, 0) for r in runs), 3) for k in keys[:9]})
for f in sorted(glob.glob("/tmp/[rc]-*-1.json")):
    r = json.load(open(f))
    print(f.split("/")[-1], {k: r.get(k) for k in ("direct_light", "hemisphere_rays", "camera_rays")})
PY
cp /tmp/rf-auto.exr /tmp/rf-cpu.exr "$OUT/"
cd - >/dev/null
stamp "GPU tests, validation required"
VKRAD_REQUIRE_VALIDATION=1 timeout 120 .dev/it gpu_rays --test-threads 4 2>&1 | grep -E "differ|disagree|rel. RMS|^test |test result" | head -40
stamp done
