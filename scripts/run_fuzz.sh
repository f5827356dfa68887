#!/bin/sh
# Runs each fuzz target for SECONDS from its seed corpus (made here, in BUILD/fuzz/corpus, so
# nothing checked in changes), from the source tree (fuzz_request reads tests/logs). A
# crash, leak, timeout or sanitizer report fails the run; its input is kept in
# BUILD/fuzz/artifacts/ to replay with `BUILD/fuzz/TARGET FILE`.
#   scripts/run_fuzz.sh BUILD SECONDS TARGET...
set -eu
build=$1
seconds=$2
shift 2
out=$build/fuzz/corpus
rm -rf "$out"
mkdir -p "$out" "$build/fuzz/artifacts"

# Requests: every request of the request logs (not the golden ones, whose replies add
# nothing), by type.
"$build/fuzz/make_corpus" "$out" $(ls tests/logs/*.lcmlog | grep -v golden)

# Mesh files: the scene's meshes and a few of assimp's test models, each behind the byte
# that makes fuzz_mesh_file give it its suffix (0 obj, 1 ply, 2 stl, 3 off, 4 dae, 5 gltf).
mkdir -p "$out/mesh_file" "$out/mesh_frame"
seed() { # byte file name
    [ -f "$2" ] || return 0
    { printf "\\$(printf '%03o' "$1")"; cat "$2"; } >"$out/mesh_file/$3"
}
for f in tests/logs/*.obj; do seed 0 "$f" "$(basename "$f")"; done
models=/usr/share/assimp/models
seed 1 $models/PLY/cube.ply cube.ply
seed 1 $models/PLY/Wuson.ply wuson.ply
seed 2 $models/STL/Spider_ascii.stl spider.stl
seed 2 $models/STL/Wuson.stl wuson.stl
seed 3 $models/OFF/Cube.off cube.off
seed 4 $models/Collada/COLLADA.dae collada.dae
seed 5 $models/glTF2/BoxTexcoords-glTF/boxTexcoords.gltf box.gltf
# Frames: what the loader child writes for some of them.
for f in tests/logs/ball.obj tests/logs/crates.obj tests/logs/garbage.obj $models/PLY/cube.ply; do
    [ -f "$f" ] && "$build/trioct-load" "$f" >"$out/mesh_frame/$(basename "$f").frame" 2>/dev/null || true
done

# Full unwinding on malloc: assimp has no frame pointers, and the suppression needs its frames.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:fast_unwind_on_malloc=0}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$(pwd)/fuzz/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
failed=""
for t in "$@"; do
    corpus=$out/${t#fuzz_}
    mkdir -p "$corpus"
    echo "== $t: $(ls "$corpus" | wc -l) seeds, $seconds s"
    if "$build/fuzz/$t" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=4096 -max_len=65536 \
        -print_final_stats=1 -artifact_prefix="$build/fuzz/artifacts/$t-" "$corpus" \
        >"$build/fuzz/$t.log" 2>&1; then
        grep -E "stat::number_of_executed_units|stat::new_units_added" "$build/fuzz/$t.log" | tr '\n' ' '
        echo
    else
        echo "FAILED: $t (log: $build/fuzz/$t.log)"
        tail -30 "$build/fuzz/$t.log"
        failed="$failed $t"
    fi
done
if [ -n "$failed" ]; then
    echo "fuzz: failed:$failed"
    exit 1
fi
echo "fuzz: every target ran $seconds s clean"
