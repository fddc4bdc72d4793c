#!/bin/bash
# Device run 4: the integration suite one test at a time (does the 16-thread segfault go?), and the rfield segment test's message.
exec > >(tee -a $OUT/log4.txt) 2>&1
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
mkdir -p /work; [ -e /work/main ] || ln -s "$PWD" /work/main
mkdir -p target/release; cp .dev/vkrad target/release/vkrad
echo "=== [${SECONDS} s] rfield segments alone"
VKRAD_REQUIRE_VALIDATION=1 timeout 40 .dev/it --exact gpu_rays::gpu_segments_agree_with_the_occluders_on_rfield --nocapture 2>&1 | grep -v "^ *[0-9]*:\|^  *at " | tail -15
echo "=== [${SECONDS} s] suite, one thread"
VKRAD_REQUIRE_VALIDATION=1 timeout 150 .dev/it --test-threads 1 --skip shaders:: --skip gpu_segments_agree_with_the_occluders_on_rfield > /tmp/it1.txt 2>&1; echo "rc=$?"
grep -E "FAILED|test result" /tmp/it1.txt | head; tail -3 /tmp/it1.txt
cp /tmp/it1.txt $OUT/it-one-thread.txt
echo "=== [${SECONDS} s] done"
