#!/usr/bin/env bash
# GPU-host measurement batch (not part of the project; travels untracked).
source .gl/gpu-env.sh
[ -e /work/main ] || { mkdir -p /work; ln -sfn "$PWD" /work/main; }
B=build/mcpt
step() { local name=$1 t=$2; shift 2; echo "== $name"; timeout $t "$@" > "$OUT/$name.txt" 2>&1; echo "rc=$?" >> "$OUT/$name.txt"; tail -4 "$OUT/$name.txt"; }
part=${1:-1}
if [ "$part" = 1 ]; then
  step devices 60 $B devices
  nvidia-smi -L > $OUT/gpu.txt 2>&1
  step render-nv-opencl 60 $B render --backend opencl --device NVIDIA --width 256 --height 256 --spp 4096 -v -q -o $OUT/cornell-nv-opencl.png
  step render-nv-vulkan 60 $B render --backend vulkan --device NVIDIA --width 256 --height 256 --spp 4096 -v -q -o $OUT/cornell-nv-vulkan.png
  step render-pocl 90 $B render --backend opencl --device Portable --width 256 --height 256 --spp 256 -v -q -o /tmp/p.png
  step compare-nv 120 $B compare cornell --a opencl:NVIDIA --b vulkan:NVIDIA --width 256 --height 256 --batches 32 --spp 16
  step converge 240 $B converge cornell --backend opencl:NVIDIA --backend vulkan:NVIDIA --backend opencl:Portable --time 6 --reference-spp 16384 -o $OUT/converge
  MCPT_TEST_OPENCL_DEVICE=NVIDIA step tests-nv 200 build/tests/mcpt_tests --gtest_filter='CompareBackends.*:*Specialized*:*Furnace*:VulkanVsOpenCl.*'
else
  step bench-spec 200 $B bench --specialize --backend opencl:NVIDIA --backend vulkan:NVIDIA --backend opencl:Portable -o $OUT/bench-specialize
  step bench 380 $B bench --models models --max-frame-seconds 3 --backend opencl:NVIDIA --backend vulkan:NVIDIA --backend opencl:Portable -o $OUT/bench
fi
