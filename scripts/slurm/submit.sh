#!/usr/bin/env bash
# Submits a tritrace render as a Slurm job array of N parts plus a merge job that runs once all of
# them succeeded, and prints the two job ids ("ARRAY_ID MERGE_ID").
#   scripts/slurm/submit.sh -n 16 -o out.exr [-d PART_DIR] [--samples SPP] [-- sbatch options] \
#       -- tritrace render scene.json --spp 1024
# --samples SPP splits the samples (at multiples of 8) instead of the image's tiles. Options after
# the first -- go to both sbatch calls (partition, time, account); the command follows the second.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
count= out= part_dir= spp=
while [ $# -gt 0 ]; do
  case "$1" in
    -n) count=$2; shift 2 ;;
    -o) out=$2; shift 2 ;;
    -d) part_dir=$2; shift 2 ;;
    --samples) spp=$2; shift 2 ;;
    --) shift; break ;;
    *) echo "submit.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
sbatch_opts=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do sbatch_opts+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
if [ -z "$count" ] || [ -z "$out" ] || [ $# -eq 0 ]; then
  echo "usage: submit.sh -n N -o OUT [-d PART_DIR] [--samples SPP] [-- SBATCH_OPTS] -- TRITRACE render ..." >&2
  exit 2
fi
part_dir=${part_dir:-$out.parts}
mkdir -p "$part_dir"
tritrace=$1
if [ -n "$spp" ]; then
  array=$(SPLIT=samples SPP=$spp sbatch --parsable --export=ALL "${sbatch_opts[@]}" \
    --array=0-$((count - 1)) "$here/render_array.sbatch" "$part_dir" "$@")
else
  array=$(SPLIT=tiles sbatch --parsable --export=ALL "${sbatch_opts[@]}" \
    --array=0-$((count - 1)) "$here/render_array.sbatch" "$part_dir" "$@")
fi
array=${array%%;*}
merge=$(sbatch --parsable "${sbatch_opts[@]}" --dependency=afterok:"$array" \
  "$here/merge.sbatch" "$part_dir" "$count" "$out" "$tritrace")
echo "${array} ${merge%%;*}"
