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
step render-nv-opencl-sah 60 $B render --backend opencl --device NVIDIA --tree sah --width 256 --height 256 --spp 4096 -q -o /tmp/a.png
step render-nv-vulkan-sah 60 $B render --backend vulkan --device NVIDIA --tree sah --width 256 --height 256 --spp 4096 -q -o /tmp/b.png
step render-pocl 90 $B render --backend opencl --device Portable --width 256 --height 256 --spp 256 -v -q -o /tmp/p.png
step compare-nv 120 $B compare cornell --a opencl:NVIDIA --b vulkan:NVIDIA --width 256 --height 256 --batches 32 --spp 16
step compare-nv-none 120 $B compare cornell --a opencl:NVIDIA --b vulkan:NVIDIA --width 256 --height 256 --batches 32 --spp 16 --tree none
step bench-spec 200 $B bench --specialize $NV -o $OUT/bench-specialize
step bench 330 $B bench --models models --max-frame-seconds 3 $NV -o $OUT/bench
