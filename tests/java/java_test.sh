#!/bin/sh
# The Java types (`make java`) and scripts/lcm-spy, headless, with no bus:
#   - the jar holds a class for every struct of proto/*.lcm and nothing else;
#   - a Java program (tests/java/TrioctLogCheck.java, compiled here against lcm.jar and the
#     jar) decodes a log that the generated C code wrote (tests/java/fixture_log.c: extreme
#     integers of every width, doubles, UTF-8, nested structs and arrays), and every field
#     checked reads as C wrote it;
#   - every trioct message in tests/logs (requests, the daemon's replies, a live recording's
#     heartbeats) decodes and encodes again to the very same bytes; the hostile logs are left
#     out, their malformed bytes are meant not to decode;
#   - in the live recording, the daemon's LIST reply names the worlds of its scene and every
#     status_t names the daemon;
#   - scripts/lcm-spy, without a display, starts Java 17 with its options, lcm-spy finds every
#     trioct type (and all its own classes, jchart2d's included), and fails cleanly, saying
#     that it needs a display.
# As root, what is missing (a JDK, liblcm-java, libjchart2d-java) is installed through
# scripts/deps.sh; otherwise the test is skipped with the apt-get line, which under CI or as
# root counts as a failure (tests/run_tests.sh).
# Prints "java_test: N passed, M failed" and exits 1 when anything failed.
#   tests/java/java_test.sh [BUILD_DIR]      ($MAKE: the make to run)
set -u
build=${1:-build}
cd "$(dirname "$0")/../.."
make=${MAKE:-make}
lcm_jar=/usr/share/java/lcm.jar
jchart2d_jar=/usr/share/java/jchart2d.jar
jar=$build/trioct-lcm-types.jar

tmp=$(mktemp -d /tmp/trioct_java_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
. tests/support/checks.sh
finish() {
    checks_summary java_test
    exit
}

missing=
command -v javac >/dev/null 2>&1 && command -v jar >/dev/null 2>&1 || missing=default-jdk-headless
[ -r $lcm_jar ] || missing="$missing liblcm-java"
[ -r $jchart2d_jar ] || missing="$missing libjchart2d-java"
if [ -n "$missing" ]; then
    if [ "$(id -u)" -ne 0 ]; then
        echo "SKIPPED: no Java to test with: sudo apt-get update && sudo apt-get install -y $missing"
        exit 77
    fi
    sh scripts/deps.sh $missing || { not_ok "scripts/deps.sh $missing"; finish; }
fi

if $make -s --no-print-directory BUILD="$build" java >"$tmp/make.log" 2>&1 && [ -r "$jar" ]; then
    ok "make java built $jar"
else
    cat "$tmp/make.log"
    not_ok "make java"
    finish
fi

# ---- the jar against proto/ --------------------------------------------------------------------
sed -n 's/^[[:space:]]*struct[[:space:]]\{1,\}\([A-Za-z0-9_]\{1,\}\).*/trioct\/\1.class/p' proto/*.lcm |
    LC_ALL=C sort >"$tmp/classes.want"
jar tf "$jar" | grep '\.class$' | LC_ALL=C sort >"$tmp/classes.got"
types=$(wc -l <"$tmp/classes.want")
if [ "$types" -gt 0 ] && diff -u "$tmp/classes.want" "$tmp/classes.got" >"$tmp/classes.diff"; then
    ok "the jar holds a class for each of the $types structs of proto/*.lcm, and no other"
else
    cat "$tmp/classes.diff"
    not_ok "the jar's classes differ from proto/*.lcm's structs (- a struct, + in the jar)"
fi
if jar tf "$jar" | grep -q '\.java$'; then
    not_ok "the jar carries Java sources"
fi

mkdir -p "$tmp/classes"
if javac -Xlint:all,-options -Werror --release 8 -cp "$lcm_jar:$jar" -d "$tmp/classes" \
    tests/java/TrioctLogCheck.java >"$tmp/javac.log" 2>&1; then
    ok "tests/java/TrioctLogCheck.java compiles against lcm.jar and the jar"
else
    cat "$tmp/javac.log"
    not_ok "tests/java/TrioctLogCheck.java does not compile"
    finish
fi
check() { java -cp "$lcm_jar:$jar:$tmp/classes" TrioctLogCheck "$@"; }

# ---- messages C encoded ----------------------------------------------------------------------------
if "$build/tests/java/fixture_log" "$tmp/fixture.lcmlog"; then
    ok "fixture_log wrote a log with the generated C encoders"
else
    not_ok "fixture_log failed"
fi
check dump "$jar" '*' "$tmp/fixture.lcmlog" >"$tmp/fixture.dump" 2>&1 ||
    not_ok "TrioctLogCheck dump of the C-encoded log failed (exit $?)"
# The fields as fixture_log.c sets them, as Java prints them (paths of nested structs and
# arrays spelled out; strings quoted, beyond ASCII as \uXXXX). Debian's lcm-gen (1.3.1)
# makes Java that reads a string a byte to a char, as Latin-1: UTF-8 text comes through as
# its bytes (the e acute as \u00c3\u00a9), which is what it encodes again.
cat >"$tmp/fixture.want" <<'EOF'
event 0 status_t on FIXTURE_STATUS
utime = 1700000000123456
daemon = "fixtured"
version = "9.8.7-\u00c3\u00a9\u00e2\u0082\u00ac"
uptime_us = 9223372036854775807
state = 3
threads = -7
queue_depth = -2147483648
queue_capacity = 2147483647
memory_used = -9223372036854775808
memory_budget = 81985529216486895
served.length = 7
served[0] = 1
served[6] = 7
malformed = -1
num_status_codes = 3
replies_by_status.length = 3
replies_by_status[0] = 10
replies_by_status[1] = 0
replies_by_status[2] = -10
latency_p99_us = 4096
num_worlds = 2
worlds.length = 2
worlds[0].name = "alpha"
worlds[0].daemon = "fixtured"
worlds[0].version = 3
worlds[0].source = "scene [alpha]"
worlds[0].accuracy = "exact"
worlds[0].seed_epsilon = 1.0E-9
worlds[0].effects = 5
worlds[0].triangles = 1099511627776
worlds[0].bbox_min.x = -0.0
worlds[0].bbox_min.y = -2.5
worlds[0].bbox_min.z = -1.0E300
worlds[0].bbox_max.x = 0.1
worlds[0].bbox_max.y = 4.9E-324
worlds[0].bbox_max.z = 1.7976931348623157E308
worlds[0].max_level = 21
worlds[0].resolution = 0.125
worlds[0].build_seconds = 1.5
worlds[0].last_error = ""
worlds[0].num_shapes = 2
worlds[0].shapes.length = 2
worlds[0].shapes[0] = "probe"
worlds[0].shapes[1] = "ring"
worlds[1].name = "beta"
worlds[1].accuracy = "fast"
worlds[1].last_error = "line 1\nline \"2\""
worlds[1].num_shapes = 0
worlds[1].shapes.length = 0
event 1 admin_reply_t on FIXTURE_LIST_REPLY
header.client_id = -81985529216486896
header.request_id = 42
header.daemon = "fixtured"
header.world = ""
header.status = -32768
header.chunk_index = 0
header.chunk_count = 1
op = 0
num_worlds = 2
worlds[0].name = "alpha"
worlds[0].shapes[1] = "ring"
worlds[1].name = "beta"
EOF
# Each wanted line, in this order (a line of the second message must come after its "event").
if awk 'NR == FNR { want[++n] = $0; next } i < n && $0 == want[i + 1] { i++ }
        END { if (i < n) { print "first missing or out of order: " want[i + 1]; exit 1 } }' \
    "$tmp/fixture.want" "$tmp/fixture.dump" >"$tmp/fixture.diff"; then
    ok "Java reads a C-encoded status_t and admin_reply_t as C wrote them ($(wc -l <"$tmp/fixture.want") lines checked)"
else
    cat "$tmp/fixture.diff"
    sed 's/^/  java: /' "$tmp/fixture.dump" | head -80
    not_ok "Java's decoding of the C-encoded log differs (above: what it printed)"
fi

# ---- tests/logs ------------------------------------------------------------------------------------
logs=$(ls tests/logs/*.lcmlog tests/logs/recorded/*.lcmlog "$tmp/fixture.lcmlog" | grep -v '/hostile\.')
if check check "$jar" $logs >"$tmp/logs.out" 2>&1; then
    ok "every trioct message of $(echo $logs | wc -w) logs decodes and encodes again to its bytes"
else
    cat "$tmp/logs.out"
    not_ok "messages of tests/logs that Java does not decode to the same bytes (above)"
fi
if grep -q ' 0 decoded' "$tmp/logs.out"; then
    grep ' 0 decoded' "$tmp/logs.out"
    not_ok "a log with no message decoded (above): its fingerprints are none of proto/'s"
fi

# ---- a live daemon's messages -----------------------------------------------------------------
live=tests/logs/recorded
daemon=$(sed -n 's/^name[[:space:]]*=[[:space:]]*\([A-Za-z0-9_]*\).*/\1/p' $live/scene.ini | head -1)
sed -n 's/^\[\(.*\)\]$/\1/p' $live/scene.ini | grep -vx daemon | LC_ALL=C sort >"$tmp/worlds.want"
check dump "$jar" '*' $live/live.lcmlog >"$tmp/live.dump" 2>&1
awk '/^event / { type = $3; list = 0 } type == "admin_reply_t" && $0 == "op = 0" { list = 1 }
     list && /^worlds\[[0-9]+\]\.name = / { gsub(/"/, "", $3); print $3 }' "$tmp/live.dump" |
    LC_ALL=C sort -u >"$tmp/worlds.got"
if [ -s "$tmp/worlds.want" ] && cmp -s "$tmp/worlds.want" "$tmp/worlds.got"; then
    ok "the recorded LIST reply names the worlds of $live/scene.ini: $(echo $(cat "$tmp/worlds.got"))"
else
    not_ok "the recorded LIST reply names '$(echo $(cat "$tmp/worlds.got"))', the scene '$(echo $(cat "$tmp/worlds.want"))'"
fi
heartbeats=$(grep -c '^event [0-9]* status_t ' "$tmp/live.dump")
named=$(grep -cx "daemon = \"$daemon\"" "$tmp/live.dump")
if [ -n "$daemon" ] && [ "$heartbeats" -gt 0 ] && [ "$heartbeats" -eq "$named" ]; then
    ok "all $heartbeats recorded status_t heartbeats name the daemon \"$daemon\""
else
    not_ok "$named of $heartbeats recorded status_t heartbeats name the daemon \"$daemon\""
fi

# ---- scripts/lcm-spy -------------------------------------------------------------------------------
# No display: lcm-spy gets as far as its window. The script's defaults (not the caller's
# overrides), and a memq:// URL, in case a bus were opened.
rc=0
env -u DISPLAY -u CLASSPATH -u TRIOCT_TYPES_JAR -u LCM_JAR -u JCHART2D_JAR -u JAVA BUILD="$build" \
    timeout 120 scripts/lcm-spy --lcm-url=memq:// >"$tmp/spy.out" 2>&1 || rc=$?
if [ $rc -ne 0 ] && [ $rc -ne 124 ] && grep -qx "Found $types LCM types" "$tmp/spy.out" &&
    ! grep -q 'ClassDiscoverer:' "$tmp/spy.out" && grep -q 'java.awt.HeadlessException' "$tmp/spy.out" &&
    grep -q '^lcm-spy: no display: DISPLAY is not set' "$tmp/spy.out"; then
    ok "scripts/lcm-spy: $(java -version 2>&1 | head -1) runs lcm.spy.Spy, which finds the $types types and every class it needs, then fails cleanly without a display"
else
    sed 's/^/  lcm-spy: /' "$tmp/spy.out"
    not_ok "scripts/lcm-spy without a display (exit $rc): not 'Found $types LCM types', a class missing, or no clean failure (above)"
fi
finish
