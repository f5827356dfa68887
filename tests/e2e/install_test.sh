#!/bin/sh
# make install, checked the way a packager and a library user meet it:
#   - `make install DESTDIR=... PREFIX=/usr` installs exactly the expected tree: every file,
#     link and directory, modes included, the binaries, libraries, headers, Python package
#     and Java types jar (when a JDK and lcm.jar built it) identical to the built ones,
#     trioct.pc with the prefix written in (and /usr/local by default);
#   - pkg-config, pointed into the DESTDIR, gives the flags that build against it, and a C
#     user including <trioct/trioct.h> and one including "trioct.h" build with them from a
#     non-standard prefix (/opt/trioct) and run;
#   - a multiarch LIBDIR (PREFIX=/usr LIBDIR=/usr/lib/<triplet>) gets the libraries and
#     trioct.pc, whose libdir says so, and the Python package loads the library from there;
#   - the installed Python package imports with its directory on sys.path and loads the
#     installed libtrioct.so.4, not the build's;
#   - client/examples/ray_example.c (C) and ray_example.cpp (C++), copied out of the tree,
#     compile against the installed header alone and link with one line against the shared
#     and against the static library, and run: no daemon on a private memq:// bus, so each
#     says so and exits 1;
#   - the shared library's soname is libtrioct.so.4 and it exports exactly the functions
#     trioct.h declares (TRIOCT_API), nothing of the generated wire code or common/;
#   - `make uninstall` with the same variables leaves no file in any of those trees and no
#     directory of trioct's own, but keeps an edited /etc/trioct/scene.ini.
# Prints "install_test: N passed, M failed" and exits 1 when anything failed.
#   tests/e2e/install_test.sh [BUILD_DIR]
# $MAKE is the make to run (the calling make's, so its variables carry over),
# $TRIOCT_TEST_SAN the sanitizer flags the build used, which the test programs need too, and
# $PYTHON the interpreter with numpy (default /usr/bin/python3, Debian's).
set -u
build=${1:-build}
cd "$(dirname "$0")/../.."
make=${MAKE:-make}
san=${TRIOCT_TEST_SAN:-}
python=${PYTHON:-/usr/bin/python3}
# A sanitized libtrioct needs the ASan runtime loaded first in an interpreter built without.
py_env=
case "$san" in
*address*) py_env="LD_PRELOAD=$(cc -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0" ;;
esac

tmp=$(mktemp -d /tmp/trioct_install_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
. tests/support/checks.sh
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
usr/bin/trioct-replay f 755
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
usr/lib/libtrioct.so l -> libtrioct.so.4
usr/lib/libtrioct.so.4 f 644
usr/lib/pkgconfig d
usr/lib/pkgconfig/trioct.pc f 644
usr/lib/python3 d
usr/lib/python3/dist-packages d
usr/lib/python3/dist-packages/trioct d
usr/lib/python3/dist-packages/trioct/_constants.py f 644
usr/lib/python3/dist-packages/trioct/_paths.py f 644
EOF
    # The Python package's modules, as many as python/trioct/ has.
    for f in python/trioct/*.py; do echo "usr/lib/python3/dist-packages/trioct/${f##*/} f 644"; done
    # The command, once client/cli/ exists.
    if ls client/cli/*.c >/dev/null 2>&1; then echo "usr/bin/trioct f 755"; fi
    # The Java types, when there is a JDK and lcm.jar to build them with (`make java`).
    if [ -f "$build/trioct-lcm-types.jar" ]; then
        printf 'usr/share/java d\nusr/share/java/trioct-lcm-types.jar f 644\n'
    fi
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
usr/share/man/man1/trioct-replay.1 f 644
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
    "$build/trioct usr/bin/trioct" "$build/trioct-replay usr/bin/trioct-replay" \
    "$build/libtrioct.a usr/lib/libtrioct.a" "$build/libtrioct.so.4 usr/lib/libtrioct.so.4" \
    "client/trioct.h usr/include/trioct/trioct.h" \
    "$build/trioct-lcm-types.jar usr/share/java/trioct-lcm-types.jar" \
    "common/trioct_limits.h usr/include/trioct/trioct_limits.h" \
    "common/trioct_status.h usr/include/trioct/trioct_status.h"; do
    set -- $pair
    [ -e "$1" ] || [ -e "$dest/$2" ] || continue # the command, before client/cli/ exists; the jar without Java
    if cmp -s "$1" "$dest/$2"; then ok "/$2 is $1"; else not_ok "/$2 differs from $1"; fi
done

# The Python package as built, but for _paths.py, which names the installed library.
for f in "$build"/python/trioct/*.py; do
    [ "${f##*/}" = _paths.py ] && continue
    to=usr/lib/python3/dist-packages/trioct/${f##*/}
    if cmp -s "$f" "$dest/$to"; then ok "/$to is $f"; else not_ok "/$to differs from $f"; fi
done

version=$(sed -n 's/^#define TRIOCT_VERSION "\(.*\)"/\1/p' common/trioct_version.h)
cat >"$tmp/pc.want" <<EOF
prefix=/usr
libdir=/usr/lib
includedir=/usr/include

Name: trioct
Description: Client library of trioctd, the collision-query daemon
Version: ${version:-0}
Cflags: -I\${includedir} -I\${includedir}/trioct
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
    [ -f "$tmp/dest-local/usr/local/lib/libtrioct.so.4" ]; then
    ok "without PREFIX: /usr/local, written into trioct.pc"
else
    not_ok "without PREFIX: not installed under /usr/local, or trioct.pc says otherwise"
fi

# ---- pkg-config --------------------------------------------------------------------------------
export PKG_CONFIG_PATH="$dest/usr/lib/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$dest"
pc() { pkg-config "$@" trioct 2>&1; }
for check in "--cflags|-I$dest/usr/include -I$dest/usr/include/trioct" "--libs|-L$dest/usr/lib -ltrioct" \
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
    if readelf -d $name 2>/dev/null | grep -q 'NEEDED.*\[libtrioct\.so\.4\]' &&
        LD_LIBRARY_PATH="$dest/usr/lib" ldd ./$name | grep -q "libtrioct.so.4 => $dest/usr/lib/libtrioct.so.4"; then
        ok "$name loads the installed libtrioct.so.4"
    else
        not_ok "$name does not load the installed libtrioct.so.4"
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
so="$dest/usr/lib/libtrioct.so.4"
if readelf -d "$so" | grep -q 'SONAME.*\[libtrioct\.so\.4\]'; then ok "soname libtrioct.so.4"; else not_ok "the soname is not libtrioct.so.4"; fi
sed -n 's/^TRIOCT_API[^(]*[ *]\(trioct_[a-z0-9_]*\)(.*/\1/p' "$dest/usr/include/trioct/trioct.h" |
    LC_ALL=C sort -u >"$tmp/api.want"
nm -D --defined-only "$so" | awk '{ print $3 }' | LC_ALL=C sort -u >"$tmp/api.got"
if [ "$(wc -l <"$tmp/api.want")" -ge 30 ] && diff -u "$tmp/api.want" "$tmp/api.got" >"$tmp/api.diff"; then
    ok "nm -D: exactly the $(wc -l <"$tmp/api.got") trioct_* functions trioct.h declares"
else
    cat "$tmp/api.diff"
    not_ok "nm -D: the exports differ from trioct.h's TRIOCT_API functions (- declared, + exported)"
fi

# ---- <trioct/trioct.h> through pkg-config, from a non-standard prefix ------------------------
opt="$tmp/dest-opt"
if quiet $make -s --no-print-directory BUILD="$build" install DESTDIR="$opt" PREFIX=/opt/trioct; then
    ok "make install DESTDIR=... PREFIX=/opt/trioct"
else
    not_ok "make install DESTDIR=... PREFIX=/opt/trioct failed"
fi
optpc() { PKG_CONFIG_PATH="$opt/opt/trioct/lib/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$opt" pkg-config "$@" trioct 2>&1; }
want="-I$opt/opt/trioct/include -I$opt/opt/trioct/include/trioct -L$opt/opt/trioct/lib -ltrioct"
got=$(optpc --cflags --libs | sed 's/ *$//')
if [ "$got" = "$want" ]; then ok "/opt/trioct: pkg-config --cflags --libs trioct: $want"; else not_ok "/opt/trioct: pkg-config gives '$got', not '$want'"; fi
# The same program both ways: the header's own quoted includes must resolve in either.
cat >"$tmp/user/angle.c" <<'EOF'
#include <trioct/trioct.h>
#include <stdio.h>
int main(void)
{
    trioct_connect_options opt = {.url = "memq://"};
    int status;
    char err[256];
    trioct_client *c = trioct_connect(&opt, &status, err, sizeof err);
    if (c == NULL) {
        fprintf(stderr, "%s\n", err);
        return 2;
    }
    trioct_admin_result res;
    int rc = trioct_info(c, "nowhere", 50, &res);
    printf("%s %d\n", trioct_status_name(rc), TRIOCT_MAX_RAYS);
    trioct_admin_result_free(&res);
    trioct_disconnect(c);
    return 0;
}
EOF
sed 's|#include <trioct/trioct.h>|#include "trioct.h"|' "$tmp/user/angle.c" >"$tmp/user/quoted.c"
for style in angle quoted; do
    line="cc -std=c11 -Wall -Wextra -Werror $san $tmp/user/$style.c $(optpc --cflags --libs) -o $tmp/user/$style"
    if ! quiet $line; then
        not_ok "/opt/trioct, $style include: $line"
        continue
    fi
    out=$(LD_LIBRARY_PATH="$opt/opt/trioct/lib" "$tmp/user/$style" 2>&1)
    if [ "$out" = "ERR_NO_DAEMON 1280" ] &&
        LD_LIBRARY_PATH="$opt/opt/trioct/lib" ldd "$tmp/user/$style" | grep -q "libtrioct.so.4 => $opt/opt/trioct/lib/libtrioct.so.4"; then
        ok "/opt/trioct, $style include: built with pkg-config, runs on the installed libtrioct.so.4"
    else
        not_ok "/opt/trioct, $style include: printed '$out', or did not load /opt/trioct's library"
    fi
done

# ---- a multiarch LIBDIR ----------------------------------------------------------------------
triplet=$(cc -print-multiarch 2>/dev/null)
[ -n "$triplet" ] || triplet=x86_64-linux-gnu
madir=/usr/lib/$triplet
ma="$tmp/dest-ma"
if quiet $make -s --no-print-directory BUILD="$build" install DESTDIR="$ma" PREFIX=/usr LIBDIR="$madir"; then
    ok "make install DESTDIR=... PREFIX=/usr LIBDIR=$madir"
else
    not_ok "make install DESTDIR=... PREFIX=/usr LIBDIR=$madir failed"
fi
if [ -f "$ma$madir/libtrioct.so.4" ] && [ -f "$ma$madir/libtrioct.a" ] && [ -L "$ma$madir/libtrioct.so" ] &&
    [ -f "$ma$madir/pkgconfig/trioct.pc" ] && ! ls "$ma"/usr/lib/libtrioct* "$ma"/usr/lib/pkgconfig >/dev/null 2>&1; then
    ok "$madir: the libraries and trioct.pc, nothing in /usr/lib"
else
    not_ok "$madir: libraries or trioct.pc missing, or some in /usr/lib instead"
fi
got=$(PKG_CONFIG_PATH="$ma$madir/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$ma" pkg-config --libs trioct 2>&1 | sed 's/ *$//')
if grep -qx "libdir=$madir" "$ma$madir/pkgconfig/trioct.pc" && [ "$got" = "-L$ma$madir -ltrioct" ]; then
    ok "$madir: trioct.pc says libdir=$madir"
else
    not_ok "$madir: trioct.pc's libdir or pkg-config --libs ('$got') wrong"
fi

# ---- the Python package, installed -----------------------------------------------------------
# Imported with only its installed directory added to sys.path (and no TRIOCT_LIBRARY), from
# outside the tree: it must load the libtrioct.so.4 installed with it, found through the
# relative path its _paths.py holds, since DESTDIR is not where the absolute one points.
py_run() {
    (cd "$tmp" && env -u TRIOCT_LIBRARY -u PYTHONPATH $py_env PYTHONPATH="$1" "$python" -c '
import trioct
print(trioct.__file__)
print(trioct.library_path)
try:
    trioct.connect("memq://", timeout_ms=50).rays("nowhere", [0, 0, 1], [0, 0, -1])
except trioct.NoReply as e:
    print(e.name)
' 2>&1)
}
for spec in "$dest|/usr/lib|/usr/lib" "$opt|/opt/trioct/lib|/opt/trioct/lib" "$ma|/usr/lib|$madir"; do
    root=${spec%%|*}
    rest=${spec#*|}
    pylib=${rest%%|*}
    libdir=${rest#*|}
    pkg="$root$pylib/python3/dist-packages"
    want="$pkg/trioct/__init__.py
$root$libdir/libtrioct.so.4
ERR_NO_DAEMON"
    got=$(py_run "$pkg")
    if [ "$got" = "$want" ] && grep -qx "LIBRARY = \"$libdir/libtrioct.so.4\"" "$pkg/trioct/_paths.py"; then
        ok "python3: import trioct from $pylib/python3/dist-packages loads $libdir/libtrioct.so.4 of that install"
    else
        printf 'expected:\n%s\ngot:\n%s\n' "$want" "$got"
        cat "$pkg/trioct/_paths.py"
        not_ok "python3: the package installed in $root$pylib did not load its own library"
    fi
done

# ---- the man pages, where man looks --------------------------------------------------------
for page in man1/trioct.1 man1/trioct-replay.1 man8/trioctd.8; do
    name=${page#*/}
    got=$(man -M "$dest/usr/share/man" -w "${name%.*}" 2>&1)
    if [ "$got" = "$dest/usr/share/man/$page" ]; then ok "man -w ${name%.*}: /usr/share/man/$page"; else not_ok "man -w ${name%.*}: '$got'"; fi
done

# ---- make uninstall ------------------------------------------------------------------------
# With the variables of each install: no file of trioct's left and no directory under its own
# names (the prefix /opt/trioct is the caller's), and a file of someone else's in a shared
# directory untouched.
files_in() { (cd "$1" && find . ! -type d | LC_ALL=C sort); }
own_dirs() { (cd "$1" && find . -type d \( -name '*trioct*' -o -name __pycache__ \) | grep -vx './opt/trioct' | LC_ALL=C sort); }
for spec in "$dest|PREFIX=/usr|usr" "$opt|PREFIX=/opt/trioct|opt/trioct" "$ma|PREFIX=/usr LIBDIR=$madir|usr"; do
    root=${spec%%|*}
    rest=${spec#*|}
    vars=${rest%%|*}
    prefix=${rest#*|}
    echo "not trioct's" >"$root/$prefix/bin/other-tool"
    if ! quiet $make -s --no-print-directory BUILD="$build" uninstall DESTDIR="$root" $vars; then
        not_ok "make uninstall DESTDIR=... $vars failed"
        continue
    fi
    left=$(files_in "$root")
    dirs=$(own_dirs "$root")
    if [ "$left" = "./$prefix/bin/other-tool" ] && [ -z "$dirs" ]; then
        ok "make uninstall DESTDIR=... $vars: no file left but another's, no directory of trioct's"
    else
        printf 'left:\n%s\n%s\n' "$left" "$dirs"
        not_ok "make uninstall DESTDIR=... $vars left the files or directories above"
    fi
done
# An edited scene is the administrator's: kept, with its directory; all else goes.
edit="$tmp/dest-edit"
quiet $make -s --no-print-directory BUILD="$build" install DESTDIR="$edit" PREFIX=/usr
echo "; edited by the admin" >>"$edit/etc/trioct/scene.ini"
if quiet $make -s --no-print-directory BUILD="$build" uninstall DESTDIR="$edit" PREFIX=/usr &&
    [ "$(files_in "$edit")" = "./etc/trioct/scene.ini" ] && grep -q 'edited by the admin' "$edit/etc/trioct/scene.ini" &&
    [ "$(own_dirs "$edit")" = "./etc/trioct" ]; then
    ok "make uninstall keeps an edited /etc/trioct/scene.ini and removes the rest"
else
    files_in "$edit"
    not_ok "make uninstall removed an edited /etc/trioct/scene.ini or left other files (above)"
fi

checks_summary install_test
