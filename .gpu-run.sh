#!/usr/bin/env bash
# GPU-host measurement batch (not part of the project; travels untracked).
source .gl/gpu-env.sh
[ -e /work/main ] || { mkdir -p /work; ln -sfn "$PWD" /work/main; }
B=build/mcpt
L=$OUT/log.txt
step() { local name=$1 t=$2; shift 2; echo "== $name: $*" | tee -a $L; timeout $t "$@" >> $L 2>&1; echo "rc=$?" | tee -a $L; }
NV="--backend opencl:NVIDIA --backend vulkan:NVIDIA --backend opencl:Portable"
step render-nv-opencl 60 $B render --backend opencl --device NVIDIA --width 256 --height 256 --spp 4096 -v -q -o /tmp/a.png
step render-nv-vulkan 60 $B render --backend vulkan --device NVIDIA --width 256 --height 256 --spp 4096 -v -q -o /tmp/b.png
step render-doc 60 $B render --backend opencl --device NVIDIA --width 512 --height 512 --spp 16384 -q -o $OUT/cornell.png
step render-pocl 90 $B render --backend opencl --device Portable --width 256 --height 256 --spp 256 -v -q -o /tmp/p.png
step compare-nv 120 $B compare cornell --a opencl:NVIDIA --b vulkan:NVIDIA --width 256 --height 256 --batches 32 --spp 64
step compare-nv-sah 120 $B compare cornell --a opencl:NVIDIA --b vulkan:NVIDIA --width 256 --height 256 --batches 32 --spp 64 --tree sah
step compare-teapot-none 120 $B compare models/teapot.glb --a opencl:NVIDIA --b vulkan:NVIDIA --width 256 --height 256 --batches 8 --spp 4 --tree none
step converge 200 $B converge cornell --backend opencl:NVIDIA --backend vulkan:NVIDIA --backend opencl:Portable --time 6 --reference-spp 16384 -o $OUT/converge
MCPT_TEST_OPENCL_DEVICE=NVIDIA step tests-nv 240 build/tests/mcpt_tests --gtest_filter='*ScaleAndPosition*:*StiffTransport*:*GlassInFurnace*:*NonFinite*:*AwkwardCamera*:CompareBackends.*:*Specialized*:*Furnace*:VulkanLoopLimit*:VulkanVsOpenCl.*'
step bench-spec 150 $B bench --specialize $NV -o $OUT/bench-specialize
step bench 300 $B bench --models models --max-frame-seconds 3 $NV -o $OUT/bench
rm -f $OUT/bench-specialize.csv
