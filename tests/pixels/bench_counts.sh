#!/usr/bin/env bash
# Prints `rtk bench`'s counts (primary_hits, ao_unoccluded, primary_ray_hash)
# per mesh and accelerator for the four meshes of docs/bench-vs-embree.md:
# equal between two builds when a change moves code without changing results.
#   tests/pixels/bench_counts.sh RTK_EXE MESH_DIR > counts.txt
set -u
[ $# -eq 2 ] || { echo "usage: $0 RTK_EXE MESH_DIR" >&2; exit 2; }
tmp=$(mktemp -d) || exit 2
trap 'rm -rf "$tmp"' EXIT
status=0
for mesh in bunny armadillo elephant dragon; do
  if ! "$1" bench "$2/$mesh.obj" --runs 1 --threads 2 --csv "$tmp/$mesh.csv" > "$tmp/$mesh.txt" 2>&1; then
    echo "$mesh: rtk bench failed:" >&2; cat "$tmp/$mesh.txt" >&2; status=1; continue
  fi
  python3 - "$mesh" "$tmp/$mesh.csv" <<'PY'
import csv, sys
for row in csv.DictReader(open(sys.argv[2])):
    print(sys.argv[1], row['accelerator'], row['primary_hits'], row['ao_unoccluded'], row['primary_ray_hash'])
PY
done
exit $status
