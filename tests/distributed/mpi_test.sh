#!/usr/bin/env bash
# `tritrace render --mpi` under a real mpirun (Open MPI): 1, 2 and 3 ranks (oversubscribed on this
# machine) give the one-process image byte for byte, with AOVs, adaptive sampling and bdpt's light
# tracing too, also when results travel in
# pieces of 1001 bytes; a rank that dies, or one that loaded another scene file, ends the job with
# a message naming it and no output file. Usage: mpi_test.sh TRITRACE
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
# Two EXR files are the same bytes but for the values of the times tritrace records in the header
# (tritrace.renderSeconds, tritrace.denoiseSeconds: a 4-byte float after name, type and size).
same_exr() {
  python3 - "$1" "$2" <<'PY'
import sys
def without_times(path):
    data = bytearray(open(path, "rb").read())
    for name in (b"tritrace.renderSeconds", b"tritrace.denoiseSeconds"):
        key = name + b"\0float\0\x04\0\0\0"
        at = data.find(key)
        if at >= 0:
            data[at + len(key):at + len(key) + 4] = bytes(4)
    return bytes(data)
sys.exit(0 if without_times(sys.argv[1]) == without_times(sys.argv[2]) else 1)
PY
}

"$cli" render "${scene[@]}" -o "$dir/one.pfm"
"$cli" render "${scene[@]}" --aovs albedo,depth,variance -o "$dir/one.exr"
for np in 1 2 3; do
  "${run_mpi[@]}" -np "$np" "$cli" render "${scene[@]}" --mpi -o "$dir/mpi$np.pfm"
  cmp "$dir/one.pfm" "$dir/mpi$np.pfm" || fail "$np ranks: the image differs from one process's"
done
"${run_mpi[@]}" -np 3 "$cli" render "${scene[@]}" --aovs albedo,depth,variance --mpi -o "$dir/mpi.exr"
same_exr "$dir/one.exr" "$dir/mpi.exr" || fail "3 ranks with AOVs: the EXR differs from one process's"
# Adaptive sampling: units are whole tile parts [0, spp), so the image and the spp AOV match.
adaptive_plain=(--scene cornell-area --spp 128 --width 48 --height 40 --threads 1 -q
  --noise-threshold 0.05)
adaptive=("${adaptive_plain[@]}" --aovs spp,variance)
"$cli" render "${adaptive[@]}" -o "$dir/adaptive.exr"
"${run_mpi[@]}" -np 3 "$cli" render "${adaptive[@]}" --mpi -o "$dir/adaptive_mpi.exr"
same_exr "$dir/adaptive.exr" "$dir/adaptive_mpi.exr" || fail "adaptive sampling: the EXR differs"
# Without the spp layer, rank 0 adds up the samples the units took: the header's mean spp is still
# the one process's.
"$cli" render "${adaptive_plain[@]}" -o "$dir/adaptive_plain.exr"
"${run_mpi[@]}" -np 2 "$cli" render "${adaptive_plain[@]}" --mpi -o "$dir/adaptive_plain_mpi.exr"
grep -q "tritrace.meanSpp" "$dir/adaptive_plain_mpi.exr" || fail "adaptive sampling: no mean spp"
same_exr "$dir/adaptive_plain.exr" "$dir/adaptive_plain_mpi.exr" ||
  fail "adaptive sampling without the spp layer: the EXR differs"
# bdpt: light tracing's splats (an integer light image, units of sample ranges over the whole
# image) merge into the one process's image too.
bdpt=(--scene cornell --integrator bdpt --spp 37 --width 33 --height 21 --threads 1 -q)
"$cli" render "${bdpt[@]}" -o "$dir/bdpt.pfm"
for np in 2 4; do
  "${run_mpi[@]}" -np "$np" "$cli" render "${bdpt[@]}" --mpi -o "$dir/bdpt_mpi$np.pfm"
  cmp "$dir/bdpt.pfm" "$dir/bdpt_mpi$np.pfm" || fail "bdpt on $np ranks: the image differs"
done
# bdpt with adaptive sampling: one unit (the whole image, samples from 0), rendered in passes.
bdpt_adaptive=(--scene cornell-area --integrator bdpt --noise-threshold 0.1 --spp 128 --width 32
  --height 24 -q)
"$cli" render "${bdpt_adaptive[@]}" -o "$dir/bdpt_adaptive.pfm"
"${run_mpi[@]}" -np 3 "$cli" render "${bdpt_adaptive[@]}" --mpi -o "$dir/bdpt_adaptive_mpi.pfm"
cmp "$dir/bdpt_adaptive.pfm" "$dir/bdpt_adaptive_mpi.pfm" ||
  fail "bdpt with adaptive sampling on 3 ranks: the image differs"
# The lab image too (one sample per pixel, tile parts only).
"$cli" render --width 48 --height 40 -q -o "$dir/lab.png"
"${run_mpi[@]}" -np 3 "$cli" render --width 48 --height 40 -q --mpi -o "$dir/lab_mpi.png"
cmp "$dir/lab.png" "$dir/lab_mpi.png" || fail "the lab image differs"

# Results cut into pieces (TRITRACE_MPI_TEST_PIECE_BYTES; 2^30 bytes by default) arrive whole.
TRITRACE_MPI_TEST_PIECE_BYTES=1001 "${run_mpi[@]}" -x TRITRACE_MPI_TEST_PIECE_BYTES -np 3 "$cli" \
  render "${scene[@]}" --aovs albedo,depth,variance --mpi -o "$dir/pieces.exr"
same_exr "$dir/one.exr" "$dir/pieces.exr" || fail "results sent in pieces: the EXR differs"

# Rank 2 loads another scene file (one material changed): the job stops before rendering, with
# one line naming rank 2, its host and what differs, and writes nothing.
scenes=$(cd "$(dirname "$0")/../../scenes" && pwd)
cp "$scenes/cornell.json" "$dir/a.json"
sed 's/"albedo": \[0.75, 0.15, 0.15\]/"albedo": [0.7, 0.15, 0.15]/' "$scenes/cornell.json" \
  >"$dir/b.json"
if cmp -s "$dir/a.json" "$dir/b.json"; then fail "the second scene file is not different"; fi
# Each rank gets its own arguments from this wrapper, by its rank in the job.
cat >"$dir/rank.sh" <<EOF
#!/usr/bin/env bash
scene="$dir/a.json"
if [ "\$OMPI_COMM_WORLD_RANK" = 2 ]; then scene="\$SECOND_SCENE"; fi
exec "$cli" render "\$scene" --width 48 --height 40 -q --mpi -o "$dir/mixed.png"
EOF
chmod +x "$dir/rank.sh"
if SECOND_SCENE="$dir/b.json" "${run_mpi[@]}" -x SECOND_SCENE -np 3 "$dir/rank.sh" \
    >"$dir/mixed.log" 2>&1; then
  fail "a job whose ranks loaded different scenes succeeded"
fi
[ "$(grep -c '^tritrace: ' "$dir/mixed.log")" = 1 ] || { cat "$dir/mixed.log" >&2; fail "not one line"; }
grep -q "^tritrace: rank 2 (host $(hostname)[^)]*) differs from rank 0: another scene (render " \
  "$dir/mixed.log" || { cat "$dir/mixed.log" >&2; fail "no line names rank 2, its host and scene"; }
[ ! -e "$dir/mixed.png" ] || fail "a job whose ranks loaded different scenes wrote its output"
# The same wrapper with one scene file for every rank renders the one-process image, so the
# refusal above is the scene's.
SECOND_SCENE="$dir/a.json" "${run_mpi[@]}" -x SECOND_SCENE -np 3 "$dir/rank.sh"
"$cli" render "$dir/a.json" --width 48 --height 40 -q -o "$dir/a.png"
cmp "$dir/a.png" "$dir/mixed.png" || fail "the wrapper's image differs from one process's"

# The render job's checks are the same under --mpi as in a plain render: --exposure with the lab
# integrator and an AOV list that only contains the names are refused, naming the flag, and
# nothing is written.
if "${run_mpi[@]}" -np 2 "$cli" render --width 48 --height 40 -q --exposure 1 --mpi \
    -o "$dir/lab_exposure.png" >"$dir/lab_exposure.log" 2>&1; then
  fail "--exposure with the lab integrator was accepted under --mpi"
fi
grep -q -- "--exposure: applies to path images" "$dir/lab_exposure.log" ||
  { cat "$dir/lab_exposure.log" >&2; fail "no line names --exposure"; }
[ ! -e "$dir/lab_exposure.png" ] || fail "a refused --exposure wrote its output"
if "${run_mpi[@]}" -np 2 "$cli" render "${scene[@]}" --aovs albedos,depths --mpi \
    -o "$dir/aovs.exr" >"$dir/aovs.log" 2>&1; then
  fail "--aovs albedos,depths was accepted under --mpi"
fi
grep -q -- "--aovs: unknown AOV 'albedos'" "$dir/aovs.log" ||
  { cat "$dir/aovs.log" >&2; fail "no line names --aovs"; }
[ ! -e "$dir/aovs.exr" ] || fail "a refused --aovs wrote its output"

# Rank 1 dies on its first unit: the job must end (not hang), fail, and name rank 1.
if TRITRACE_MPI_TEST_DIE=1 "${run_mpi[@]}" -x TRITRACE_MPI_TEST_DIE -np 3 "$cli" render \
    "${scene[@]}" --mpi -o "$dir/dead.pfm" >"$dir/dead.log" 2>&1; then
  fail "a job whose rank died succeeded"
fi
grep -q "rank 1" "$dir/dead.log" || { cat "$dir/dead.log" >&2; fail "no message names rank 1"; }
[ ! -e "$dir/dead.pfm" ] || fail "a job whose rank died wrote its output"
echo "mpi_test: 1, 2 and 3 ranks match one process byte for byte, in pieces too; a dying rank" \
  "and a rank with another scene file are named; the job's checks refuse what render refuses"
