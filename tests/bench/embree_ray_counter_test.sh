#!/usr/bin/env bash
# bench/embree_ray_counter.cpp counts the rays of Embree's `pathtracer` tutorial: every
# camera ray is one rtcIntersect1 call, so a frame of W x H at S spp counts at least W*H*S;
# twice the spp counts more; the same run counts the same (the tutorial's sampling is
# keyed by pixel and sample). Usage: embree_ray_counter_test.sh LIBRARY MESH
set -euo pipefail
lib="$(readlink -f "$1")"; mesh="$2"
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
count() {  # spp -> rays counted
  RAYLINE_RAY_COUNT_FILE="$work/rays.txt" LD_PRELOAD="$lib" pathtracer -i "$mesh" --size 16 16 --spp "$1" \
    --max-path-length 4 --threads 1 --directionallight 0 -1 0 1 1 1 -o "$work/out.ppm" > "$work/log" 2>&1 \
    || { cat "$work/log"; exit 1; }
  cat "$work/rays.txt"
}
one=$(count 1); again=$(count 1); two=$(count 2)
echo "rays counted: 1 spp $one, again $again, 2 spp $two"
[ "$one" -ge 256 ] || { echo "fewer rays than camera rays (256)"; exit 1; }
[ "$one" = "$again" ] || { echo "the same run counted differently"; exit 1; }
[ "$two" -gt "$one" ] && [ "$two" -ge 512 ] || { echo "2 spp did not count more"; exit 1; }
