#!/bin/sh
# make install, checked the way a packager and a library user meet it:
#   - `make install DESTDIR=... PREFIX=/usr` installs exactly the expected tree: every file,
#     link and directory, modes included, the binaries, libraries and headers identical to
#     the built ones, trioct.pc with the prefix written in (and /usr/local by default);
#   - pkg-config, pointed into the DESTDIR, gives the flags that build against it;
#   - client/examples/ray_example.c (C) and ray_example.cpp (C++), copied out of the tree,
#     compile against the installed header alone and link with one line against the shared
#     and against the static library, and run: no daemon on a private memq:// bus, so each
#     says so and exits 1;
#   - the shared library's soname is libtrioct.so.2 and it exports exactly the functions
#     trioct.h declares (TRIOCT_API), nothing of the generated wire code or common/.
# Prints "install_test: N passed, M failed" and exits 1 when anything failed.
#   tests/e2e/install_test.sh [BUILD_DIR]
# $MAKE is the make to run (the calling make's, so its variables carry over) and
# $TRIOCT_TEST_SAN the sanitizer flags the build used, which the test programs need too.
set -u
build=${1:-build}
cd "$(dirname "$0")/../.."
make=${MAKE:-make}
san=${TRIOCT_TEST_SAN:-}

tmp=$(mktemp -d /tmp/trioct_install_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
ok() {
    passed=$((passed + 1))
    echo "ok: $1"
}
not_ok() {
    failed=$((failed + 1))
    echo "FAILED: $1"
}
# Runs "$@", printing its output only when it fails.
quiet() {
    "$@" >"$tmp/cmd.log" 2>&1 && return 0
    cat "$tmp/cmd.log"
    return 1
}

for tool in pkg-config nm readelf g++; do
    command -v $tool >/dev/null 2>&1 || not_ok "$tool is missing (scripts/deps.sh installs it)"
done

# ---- the installed tree ----------------------------------------------------------------------
dest="$tmp/dest"
if quiet $make -s --no-print-directory BUILD="$build" install DESTDIR="$dest" PREFIX=/usr; then
    ok "make install DESTDIR=... PREFIX=/usr"
else
    not_ok "make install DESTDIR=... PREFIX=/usr failed"
fi

# Every entry: "PATH d" for a directory, "PATH f MODE" for a file, "PATH l -> TARGET".
(cd "$dest" 2>/dev/null && find . -mindepth 1 -printf '%P %y %m %l\n') |
    awk '$2 == "d" { print $1 " d"; next } $2 == "l" { print $1 " l -> " $4; next } { print $1 " " $2 " " $3 }' |
    LC_ALL=C sort >"$tmp/tree.got"
{
    cat <<'EOF'
usr d
usr/bin d
usr/bin/trioctd f 755
usr/include d
usr/include/trioct d
usr/include/trioct/trioct.h f 644
usr/include/trioct/trioct_limits.h f 644
usr/include/trioct/trioct_status.h f 644
usr/libexec d
usr/libexec/trioct d
usr/libexec/trioct/trioct-load f 755
usr/lib d
usr/lib/libtrioct.a f 644
usr/lib/libtrioct.so l -> libtrioct.so.2
usr/lib/libtrioct.so.2 f 644
usr/lib/pkgconfig d
usr/lib/pkgconfig/trioct.pc f 644
EOF
    # The command, once client/cli/ exists.
    if ls client/cli/*.c >/dev/null 2>&1; then echo "usr/bin/trioct f 755"; fi
    # install-service (issue 7): the unit, the example scene, the man pages; their contents
    # are tests/e2e/systemd_test.sh's to check.
    cat <<'EOF'
etc d
etc/trioct d
etc/trioct/scene.ini f 644
etc/trioct/worlds d
usr/lib/systemd d
usr/lib/systemd/system d
usr/lib/systemd/system/trioctd.service f 644
usr/share d
usr/share/man d
usr/share/man/man1 d
usr/share/man/man1/trioct.1 f 644
usr/share/man/man8 d
usr/share/man/man8/trioctd.8 f 644
usr/share/trioct d
usr/share/trioct/scene.ini.example f 644
EOF
} | LC_ALL=C sort >"$tmp/tree.want"
if diff -u "$tmp/tree.want" "$tmp/tree.got" >"$tmp/tree.diff"; then
    ok "the installed tree is exactly the $(wc -l <"$tmp/tree.want") expected entries"
else
    cat "$tmp/tree.diff"
    not_ok "the installed tree differs from the expected one (- expected, + installed)"
fi

for pair in "$build/trioctd usr/bin/trioctd" "$build/trioct-load usr/libexec/trioct/trioct-load" \
    "$build/trioct usr/bin/trioct" \
    "$build/libtrioct.a usr/lib/libtrioct.a" "$build/libtrioct.so.2 usr/lib/libtrioct.so.2" \
    "client/trioct.h usr/include/trioct/trioct.h" \
    "common/trioct_limits.h usr/include/trioct/trioct_limits.h" \
    "common/trioct_status.h usr/include/trioct/trioct_status.h"; do
    set -- $pair
    [ -e "$1" ] || [ -e "$dest/$2" ] || continue # the command, before client/cli/ exists
    if cmp -s "$1" "$dest/$2"; then ok "/$2 is $1"; else not_ok "/$2 differs from $1"; fi
done

version=$(sed -n 's/^#define TRIOCT_VERSION "\(.*\)"/\1/p' common/trioct_version.h)
cat >"$tmp/pc.want" <<EOF
prefix=/usr
libdir=/usr/lib
includedir=\${prefix}/include

Name: trioct
Description: Client library of trioctd, the collision-query daemon
Version: ${version:-0}
Cflags: -I\${includedir}/trioct
Libs: -L\${libdir} -ltrioct
Libs.private: -llcm -lsodium -lm
EOF
if diff -u "$tmp/pc.want" "$dest/usr/lib/pkgconfig/trioct.pc"; then
    ok "trioct.pc names /usr and /usr/lib, version ${version:-0}"
else
    not_ok "trioct.pc differs (- expected, + installed)"
fi

# The default prefix.
if quiet $make -s --no-print-directory BUILD="$build" install-lib DESTDIR="$tmp/dest-local" &&
    grep -qx 'prefix=/usr/local' "$tmp/dest-local/usr/local/lib/pkgconfig/trioct.pc" &&
    grep -qx 'libdir=/usr/local/lib' "$tmp/dest-local/usr/local/lib/pkgconfig/trioct.pc" &&
    [ -f "$tmp/dest-local/usr/local/include/trioct/trioct.h" ] &&
    [ -f "$tmp/dest-local/usr/local/lib/libtrioct.so.2" ]; then
    ok "without PREFIX: /usr/local, written into trioct.pc"
else
    not_ok "without PREFIX: not installed under /usr/local, or trioct.pc says otherwise"
fi

# ---- pkg-config --------------------------------------------------------------------------------
export PKG_CONFIG_PATH="$dest/usr/lib/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$dest"
pc() { pkg-config "$@" trioct 2>&1; }
for check in "--cflags|-I$dest/usr/include/trioct" "--libs|-L$dest/usr/lib -ltrioct" \
    "--static --libs|-L$dest/usr/lib -ltrioct -llcm -lsodium -lm" "--modversion|${version:-0}"; do
    args=${check%%|*}
    want=${check#*|}
    got=$(pc $args | sed 's/ *$//')
    if [ "$got" = "$want" ]; then ok "pkg-config $args trioct: $want"; else not_ok "pkg-config $args trioct: '$got', not '$want'"; fi
done

# ---- C and C++ users -------------------------------------------------------------------------
# Out of the tree, so that only the installed header can be found.
mkdir -p "$tmp/user"
cp client/examples/ray_example.c client/examples/ray_example.cpp "$tmp/user/"
cd "$tmp/user"
cflags=$(pc --cflags)
libs=$(pc --libs)
# The header alone, also as <trioct/trioct.h> from the include root, strict C99.
if printf '#include <trioct/trioct.h>\nint main(void) { return trioct_status_text(0)[0] != 0x6f; }\n' |
    quiet cc -std=c99 -pedantic -Wall -Wextra -Werror -I"$dest/usr/include" -x c -o /dev/null -; then
    ok "<trioct/trioct.h> finds the headers beside it (C99, -pedantic)"
else
    not_ok "<trioct/trioct.h> does not compile on its own"
fi
# One line each; static: libtrioct from its archive, LCM, libsodium and libm (Libs.private) shared.
link_c_shared="cc -std=c11 -Wall -Wextra -Werror $san ray_example.c $cflags $libs -o c_shared"
link_c_static="cc -std=c11 -Wall -Wextra -Werror $san ray_example.c $cflags -Wl,-Bstatic $libs -Wl,-Bdynamic -llcm -lsodium -lm -o c_static"
link_cxx_shared="g++ -std=c++11 -pedantic -Wall -Wextra -Werror $san ray_example.cpp $cflags $libs -o cxx_shared"
link_cxx_static="g++ -std=c++11 -pedantic -Wall -Wextra -Werror $san ray_example.cpp $cflags -Wl,-Bstatic $libs -Wl,-Bdynamic -llcm -lsodium -lm -o cxx_static"
for name in c_shared c_static cxx_shared cxx_static; do
    eval "line=\$link_$name"
    if quiet $line; then ok "$name: $line"; else not_ok "$name: $line"; fi
done
for name in c_shared cxx_shared; do
    if readelf -d $name 2>/dev/null | grep -q 'NEEDED.*\[libtrioct\.so\.2\]' &&
        LD_LIBRARY_PATH="$dest/usr/lib" ldd ./$name | grep -q "libtrioct.so.2 => $dest/usr/lib/libtrioct.so.2"; then
        ok "$name loads the installed libtrioct.so.2"
    else
        not_ok "$name does not load the installed libtrioct.so.2"
    fi
done
for name in c_static cxx_static; do
    if [ -x $name ] && ! readelf -d $name | grep -q 'libtrioct'; then
        ok "$name carries libtrioct itself"
    else
        not_ok "$name is missing or needs libtrioct.so"
    fi
done
# No daemon on a private memq:// bus: every request says so, exit 1.
nodaemon="no daemon serves world nowhere on memq:// (no reply within 50 ms)"
for name in c_shared c_static cxx_shared cxx_static; do
    LD_LIBRARY_PATH="$dest/usr/lib" ./$name nowhere memq:// 50 >"$tmp/run.out" 2>"$tmp/run.err"
    rc=$?
    case $name in
    c_*) want=5 ;; # info, then four ray batches
    *) want=1 ;;
    esac
    got=$(grep -c "$nodaemon" "$tmp/run.err")
    if [ $rc -eq 1 ] && [ "$got" -eq $want ]; then
        ok "$name runs: exit 1, \"$nodaemon\" $want times"
    else
        cat "$tmp/run.out" "$tmp/run.err"
        not_ok "$name: exit $rc, the no-daemon message $got times, not $want"
    fi
done
cd - >/dev/null

# ---- what the shared library exports -------------------------------------------------------
so="$dest/usr/lib/libtrioct.so.2"
if readelf -d "$so" | grep -q 'SONAME.*\[libtrioct\.so\.2\]'; then ok "soname libtrioct.so.2"; else not_ok "the soname is not libtrioct.so.2"; fi
sed -n 's/^TRIOCT_API[^(]*[ *]\(trioct_[a-z0-9_]*\)(.*/\1/p' "$dest/usr/include/trioct/trioct.h" |
    LC_ALL=C sort -u >"$tmp/api.want"
nm -D --defined-only "$so" | awk '{ print $3 }' | LC_ALL=C sort -u >"$tmp/api.got"
if [ "$(wc -l <"$tmp/api.want")" -ge 30 ] && diff -u "$tmp/api.want" "$tmp/api.got" >"$tmp/api.diff"; then
    ok "nm -D: exactly the $(wc -l <"$tmp/api.got") trioct_* functions trioct.h declares"
else
    cat "$tmp/api.diff"
    not_ok "nm -D: the exports differ from trioct.h's TRIOCT_API functions (- declared, + exported)"
fi

echo "install_test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
