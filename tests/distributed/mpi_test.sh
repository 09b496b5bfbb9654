#!/usr/bin/env bash
# `tritrace render --mpi` under a real mpirun (Open MPI): 1, 2 and 3 ranks (oversubscribed on this
# machine) give the one-process image byte for byte, with AOVs too; a rank that dies ends the job
# with a message naming it and no output file. Usage: mpi_test.sh TRITRACE
set -euo pipefail
cli=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
run_mpi=(timeout 120 mpirun --oversubscribe --bind-to none)
if [ "$(id -u)" -eq 0 ]; then run_mpi+=(--allow-run-as-root); fi
# Containers often forbid the cross-memory attach Open MPI's shared-memory transport tries first.
export OMPI_MCA_btl_vader_single_copy_mechanism=none
scene=(--scene cornell-area --spp 20 --width 48 --height 40 --threads 1 -q)
fail() { echo "mpi_test: $*" >&2; exit 1; }

"$cli" render "${scene[@]}" -o "$dir/one.pfm"
"$cli" render "${scene[@]}" --aovs albedo,depth -o "$dir/one.exr"
for np in 1 2 3; do
  "${run_mpi[@]}" -np "$np" "$cli" render "${scene[@]}" --mpi -o "$dir/mpi$np.pfm"
  cmp "$dir/one.pfm" "$dir/mpi$np.pfm" || fail "$np ranks: the image differs from one process's"
done
"${run_mpi[@]}" -np 3 "$cli" render "${scene[@]}" --aovs albedo,depth --mpi -o "$dir/mpi.exr"
cmp "$dir/one.exr" "$dir/mpi.exr" || fail "3 ranks with AOVs: the EXR differs from one process's"
# The lab image too (one sample per pixel, tile parts only).
"$cli" render --width 48 --height 40 -q -o "$dir/lab.png"
"${run_mpi[@]}" -np 3 "$cli" render --width 48 --height 40 -q --mpi -o "$dir/lab_mpi.png"
cmp "$dir/lab.png" "$dir/lab_mpi.png" || fail "the lab image differs"

# Rank 1 dies on its first unit: the job must end (not hang), fail, and name rank 1.
if TRITRACE_MPI_TEST_DIE=1 "${run_mpi[@]}" -x TRITRACE_MPI_TEST_DIE -np 3 "$cli" render \
    "${scene[@]}" --mpi -o "$dir/dead.pfm" >"$dir/dead.log" 2>&1; then
  fail "a job whose rank died succeeded"
fi
grep -q "rank 1" "$dir/dead.log" || { cat "$dir/dead.log" >&2; fail "no message names rank 1"; }
[ ! -e "$dir/dead.pfm" ] || fail "a job whose rank died wrote its output"
echo "mpi_test: 1, 2 and 3 ranks match one process byte for byte; a dying rank is named"
