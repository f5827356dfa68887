# Sourced by what starts scripts/run_demo.sh in the background and then uses the demo
# (scripts/render_demo.sh, tests/e2e/demo_test.sh):
#   demo_wait BUILD LOG PID
# waits until the demo of run_demo.sh (PID, its output in LOG) is up: its netns.env written
# and its instructions printed. Returns 0, or 1 with why on stdout (120 s passed, or the
# demo ended first).
demo_wait() {
    _i=0
    until [ -f "$1/demo/netns.env" ] && grep -q "Ctrl-C stops it" "$2"; do
        _i=$((_i + 1))
        if [ $_i -gt 600 ]; then
            echo "the demo was not up within 120 s"
            return 1
        fi
        if ! kill -0 "$3" 2>/dev/null; then
            echo "the demo ended before it was up"
            return 1
        fi
        sleep 0.2
    done
}
