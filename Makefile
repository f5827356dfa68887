# trioct build. `make` builds, `make test` runs every test, `make asan` runs them under
# AddressSanitizer + UndefinedBehaviorSanitizer, `make bench` prints the benchmarks.

CC      ?= cc
BUILD   ?= build
OPT     ?= -O2 -g
# -ffp-contract=off: the predicates' error bounds assume every operation is rounded on its
# own; a fused multiply-add would change the arithmetic under them.
CFLAGS_BASE = -std=c11 -D_POSIX_C_SOURCE=200809L -Wall -Wextra -Werror -ffp-contract=off \
              -fno-strict-aliasing -Iserver -Iclient -Itests -Icommon -I$(GEN_DIR) -pthread
CFLAGS  ?=
ALL_CFLAGS = $(CFLAGS_BASE) $(OPT) $(SAN) $(CFLAGS)
LDLIBS_ENGINE = -lm -pthread

ENGINE_SRC := $(wildcard server/geom/*.c server/octree/*.c)
WORLD_SRC  := $(wildcard server/world/*.c)
COMMON_SRC := $(wildcard common/*.c)
SERVICE_SRC := $(filter-out server/service/trioctd.c,$(wildcard server/service/*.c))
CLIENT_SRC := $(wildcard client/*.c)
DAEMON_BIN := $(BUILD)/trioctd

# The wire format: C generated from proto/*.lcm by lcm-gen into the build tree, never committed.
PROTO      := $(wildcard proto/*.lcm)
GEN_DIR    := $(BUILD)/gen
GEN_STAMP  := $(GEN_DIR)/.stamp
GEN_SRC    := $(PROTO:proto/%.lcm=$(GEN_DIR)/trioct_%.c)
GEN_OBJ    := $(GEN_SRC:.c=.o)
SUPPORT_SRC := $(wildcard tests/support/*.c)
TEST_SRC   := $(wildcard tests/test_*.c)
BENCH_SRC  := $(wildcard bench/bench_*.c)
DEMO_BIN   := $(BUILD)/trioct-demo
DEMO_WORLD_BIN := $(BUILD)/make-demo-world
DEMO_DIR   := $(BUILD)/demo
ACC_BIN    := $(BUILD)/bench/report_accuracy

ENGINE_OBJ  := $(ENGINE_SRC:%.c=$(BUILD)/%.o)
WORLD_OBJ   := $(WORLD_SRC:%.c=$(BUILD)/%.o)
COMMON_OBJ  := $(COMMON_SRC:%.c=$(BUILD)/%.o)
SERVICE_OBJ := $(SERVICE_SRC:%.c=$(BUILD)/%.o)
CLIENT_OBJ  := $(CLIENT_SRC:%.c=$(BUILD)/%.o)
SUPPORT_OBJ := $(SUPPORT_SRC:%.c=$(BUILD)/%.o)
TEST_BIN    := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)
BENCH_BIN   := $(BENCH_SRC:bench/%.c=$(BUILD)/bench/%)

ENGINE_LIB  := $(BUILD)/libtrioct_engine.a
WORLD_LIB   := $(BUILD)/libtrioct_world.a
PROTO_LIB   := $(BUILD)/libtrioct_proto.a
SERVICE_LIB := $(BUILD)/libtrioct_service.a
CLIENT_LIB  := $(BUILD)/libtrioct.a
SUPPORT_LIB := $(BUILD)/libtestsupport.a
DEPS_STAMP  := $(BUILD)/.deps-ok

.PHONY: all deps test asan bench run clean accuracy-report
# Keep objects make would delete as intermediates, so a relink does not recompile.
.SECONDARY:
all: $(ENGINE_LIB) $(WORLD_LIB) $(PROTO_LIB) $(SERVICE_LIB) $(if $(wildcard server/service/trioctd.c),$(DAEMON_BIN)) $(TEST_BIN) $(BENCH_BIN) $(DEMO_BIN)

deps: $(DEPS_STAMP)
$(DEPS_STAMP): scripts/deps.sh
	@mkdir -p $(BUILD)
	@sh scripts/deps.sh
	@touch $@

$(BUILD)/%.o: %.c | $(DEPS_STAMP) $(GEN_STAMP)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -MMD -MP -c $< -o $@

$(GEN_STAMP): $(PROTO) | $(DEPS_STAMP)
	rm -rf $(GEN_DIR) && mkdir -p $(GEN_DIR)
	lcm-gen -c --c-cpath $(GEN_DIR) --c-hpath $(GEN_DIR) $(PROTO)
	@touch $@
$(GEN_SRC): $(GEN_STAMP)
# lcm-gen's C has unused parameters; only its warnings are relaxed. Each object depends on
# the stamp itself too: the stamp's recipe empties GEN_DIR, objects included, and an
# object make had already found newer than its .c (a prerequisite without a recipe) was
# then missing when ar ran, the first make -j after a proto change.
$(GEN_OBJ): $(GEN_STAMP)
$(GEN_DIR)/%.o: $(GEN_DIR)/%.c
	$(CC) $(ALL_CFLAGS) -Wno-unused-parameter -c $< -o $@

$(ENGINE_LIB): $(ENGINE_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(WORLD_LIB): $(WORLD_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(PROTO_LIB): $(GEN_OBJ) $(COMMON_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(SERVICE_LIB): $(SERVICE_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(SUPPORT_LIB): $(SUPPORT_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
# libtrioct, the client library: self-contained, so it carries the generated wire code and
# common/ as well (a program linking it and libtrioct_proto.a gets each object once).
$(CLIENT_LIB): $(CLIENT_OBJ) $(GEN_OBJ) $(COMMON_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^

ALL_LIBS = $(SUPPORT_LIB) $(SERVICE_LIB) $(WORLD_LIB) $(CLIENT_LIB) $(PROTO_LIB) $(ENGINE_LIB)
SYS_LIBS = -lgmp -lassimp -llcm -lsodium -luv -linih $(LDLIBS_ENGINE)
$(BUILD)/tests/%: $(BUILD)/tests/%.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) -lcmocka $(SYS_LIBS) -o $@

# End to end over udpm, inside a private network namespace (tests/e2e/netns.sh).
E2E_BIN := $(BUILD)/tests/e2e_daemon
$(E2E_BIN): $(BUILD)/tests/e2e/e2e_daemon.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) -lcmocka $(SYS_LIBS) -o $@

# The trioct command (issue 5): client/cli/, linked with libtrioct.a and none of the daemon's
# service code; `mesh --shape-file` reads its file with the daemon's assimp reader, the one
# self-contained part of server/ it takes (CLI_MESH_LOAD_OBJ), so that a file gives the CLI
# the triangles it gives a scene. Its pure parts (arguments, CSV, poses, JSON, text,
# progress) are unit-tested by test_cli_parse; e2e_cli runs the command against a real
# daemon inside netns.sh.
CLI_SRC      := $(wildcard client/cli/*.c)
CLI_OBJ      := $(CLI_SRC:%.c=$(BUILD)/%.o)
CLI_MESH_LOAD_OBJ := $(addprefix $(BUILD)/server/world/,mesh_load.o mesh_data.o error_text.o)
CLI_PURE_OBJ := $(addprefix $(BUILD)/client/cli/,cli_args.o cli_csv.o cli_pose.o cli_json.o cli_text.o cli_progress.o \
                  cli_camera.o cli_render.o cli_png.o cli_distance_args.o)
CLI_BIN      := $(BUILD)/trioct
E2E_CLI_BIN  := $(BUILD)/tests/e2e_cli
all: $(CLI_BIN)
$(CLI_BIN): $(CLI_OBJ) $(CLI_MESH_LOAD_OBJ) $(CLIENT_LIB)
	$(CC) $(ALL_CFLAGS) $(CLI_OBJ) $(CLI_MESH_LOAD_OBJ) $(CLIENT_LIB) -lassimp -llcm -lsodium -lpng -lm -pthread -o $@
$(BUILD)/tests/test_cli_parse: $(BUILD)/tests/test_cli_parse.o $(CLI_PURE_OBJ)
	$(CC) $(ALL_CFLAGS) $< $(CLI_PURE_OBJ) -lcmocka -lpng -lm -o $@
$(E2E_CLI_BIN): $(BUILD)/tests/e2e/e2e_cli.o $(BUILD)/client/cli/cli_png.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(BUILD)/client/cli/cli_png.o $(ALL_LIBS) -lcmocka -lpng $(SYS_LIBS) -o $@
# A depth picture checked pixel by pixel against the daemon's rays (tests/e2e/demo_test.sh).
RENDER_CHECK_BIN := $(BUILD)/tests/render_check
RENDER_CHECK_OBJ := $(addprefix $(BUILD)/client/cli/,cli_args.o cli_camera.o cli_png.o cli_render.o)
$(RENDER_CHECK_BIN): $(BUILD)/tests/e2e/render_check.o $(RENDER_CHECK_OBJ) $(CLIENT_LIB)
	$(CC) $(ALL_CFLAGS) $< $(RENDER_CHECK_OBJ) $(CLIENT_LIB) -llcm -lsodium -lpng -lm -pthread -o $@
test: $(CLI_BIN) $(E2E_CLI_BIN) $(RENDER_CHECK_BIN) $(DEMO_BIN) $(DEMO_DIR)/.stamp

EDITS_BENCH_BIN := $(BUILD)/bench/edits_bench
$(EDITS_BENCH_BIN): $(BUILD)/bench/edits_bench.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@
# Issue 20: the daemon under sustained load (bench/load_bench.c), three phases of
# LOAD_BENCH_SECONDS (default 60): steady, reloads every 2 s, a kill -9 and restart.
LOAD_BENCH_BIN := $(BUILD)/bench/load_bench
LOAD_BENCH_SECONDS ?= 60
$(LOAD_BENCH_BIN): $(BUILD)/bench/load_bench.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@
.PHONY: bench-load
bench-load: $(LOAD_BENCH_BIN) $(DAEMON_BIN)
	tests/e2e/netns.sh $(LOAD_BENCH_BIN) $(DAEMON_BIN) $(LOAD_BENCH_SECONDS)
DAEMON_BENCH_BIN := $(BUILD)/bench/daemon_bench
$(DAEMON_BENCH_BIN): $(BUILD)/bench/daemon_bench.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@

$(BUILD)/bench/%: $(BUILD)/bench/%.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@

$(ACC_BIN): $(BUILD)/bench/report_accuracy.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@

$(DEMO_BIN): $(BUILD)/tools/trioct_demo.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@

$(DEMO_WORLD_BIN): $(BUILD)/tools/make_demo_world.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) $(SYS_LIBS) -o $@
$(DEMO_DIR)/.stamp: $(DEMO_WORLD_BIN)
	$(DEMO_WORLD_BIN) $(DEMO_DIR)
	@touch $@

$(DAEMON_BIN): $(BUILD)/server/service/trioctd.o $(SERVICE_LIB) $(WORLD_LIB) $(PROTO_LIB) $(ENGINE_LIB) | $(LOADER_BIN)
	$(CC) $(ALL_CFLAGS) $< $(SERVICE_LIB) $(WORLD_LIB) $(PROTO_LIB) $(ENGINE_LIB) $(SYS_LIBS) -o $@

# trioct-load (issue 20): the daemon parses every mesh file in one of these, a confined
# child process, and looks for it beside its own executable (or in ../libexec/trioct/).
LOADER_BIN := $(BUILD)/trioct-load
LOADER_CONFINE_OBJ := $(BUILD)/server/loader/loader_confine.o
$(LOADER_BIN): $(BUILD)/server/loader/trioct_load.o $(LOADER_CONFINE_OBJ) $(WORLD_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) $< $(LOADER_CONFINE_OBJ) $(WORLD_LIB) $(ENGINE_LIB) -lassimp -lseccomp $(LDLIBS_ENGINE) -o $@
all: $(LOADER_BIN)
# test_loader's fake loaders confine themselves with the loader's own code.
$(BUILD)/tests/test_loader: $(BUILD)/tests/test_loader.o $(LOADER_CONFINE_OBJ) $(ALL_LIBS) | $(LOADER_BIN)
	$(CC) $(ALL_CFLAGS) $< $(LOADER_CONFINE_OBJ) $(ALL_LIBS) -lcmocka $(SYS_LIBS) -lseccomp -o $@

# The daemon on the demo scene, in a private network namespace, after a demo client's
# questions. Every program is built first, so scripts/demo-shell finds trioct and the rest.
run: all $(DEMO_DIR)/.stamp
	sh scripts/run_demo.sh $(BUILD)

# Every test program runs even when one fails, and the target fails if any did; the last
# line counts passed, failed and skipped programs and names the others (tests/run_tests.sh).
# The end-to-end runs need root for their namespace; without it they are skipped and said
# so. Under CI (CI=true) or as root a skip is a failure.
test: $(TEST_BIN) $(E2E_BIN) $(DAEMON_BIN)
	@TEST_BIN="$(TEST_BIN)" E2E_BIN="$(E2E_BIN)" E2E_CLI_BIN="$(E2E_CLI_BIN)" DAEMON_BIN="$(DAEMON_BIN)" \
	    CLI_BIN="$(CLI_BIN)" MAKE="$(MAKE)" SAN="$(SAN)" PYTHON="$(PYTHON)" CC="$(CC)" sh tests/run_tests.sh $(BUILD)

asan:
	$(MAKE) BUILD=build-asan OPT="-O1 -g -fno-omit-frame-pointer" \
	    SAN="-fsanitize=address,undefined -fno-sanitize-recover=all" test

bench: $(BENCH_BIN) $(DAEMON_BENCH_BIN) $(EDITS_BENCH_BIN) $(DAEMON_BIN)
	@for b in $(BENCH_BIN); do echo "== $$b"; $$b || exit 1; done
	@echo "== $(DAEMON_BENCH_BIN) (udpm in a private network namespace)"
	tests/e2e/netns.sh $(DAEMON_BENCH_BIN) $(DAEMON_BIN)
	@echo "== $(EDITS_BENCH_BIN) (udpm in a private network namespace)"
	tests/e2e/netns.sh $(EDITS_BENCH_BIN) $(DAEMON_BIN)
	@$(MAKE) --no-print-directory bench-peers

# trioct against its peers, Embree 3 (rays, builds) and FCL 0.7 (triangles, a shape at
# poses), on one core (bench/peers/). Only this binary links them: it is outside BENCH_SRC
# and `all`, and is built only here, after bench/peers/ensure_peers.sh has found the
# packages (installing them as root); without them and without root it prints the apt-get
# line and the peer benchmark is skipped. FCL's headers come in as system headers, so
# their warnings do not fail the build.
CXX ?= g++
PEER_BIN   := $(BUILD)/bench/peers/bench_peers
PEER_OBJ   := $(BUILD)/bench/peers/bench_peers.o $(BUILD)/bench/peers/fcl_peer.o
PEER_CXXFLAGS = -std=c++17 -Wall -Wextra -Werror -isystem /usr/include/eigen3 $(OPT) $(SAN) $(CXXFLAGS)
PEER_LIBS  := -lembree3 -lfcl
PEER_ENSURE ?= bench/peers/ensure_peers.sh
.PHONY: bench-peers
bench-peers:
	@st=0; sh $(PEER_ENSURE) || st=$$?; \
	if [ $$st -eq 3 ]; then echo "== $(PEER_BIN) skipped: Embree and FCL are not installed"; \
	elif [ $$st -ne 0 ]; then exit $$st; \
	else $(MAKE) --no-print-directory $(PEER_BIN) $(STATES_BIN) $(DISTANCE_BIN) && \
	    echo "== $(PEER_BIN) (trioct vs Embree and FCL, one core)" && $(PEER_BIN) && \
	    echo "== $(STATES_BIN) (robot states: trioct vs FCL's broadphase and narrow phase, one core)" && \
	    $(STATES_BIN) && \
	    echo "== $(DISTANCE_BIN) (distances: trioct vs FCL's distance, one core)" && $(DISTANCE_BIN); fi
STATES_BIN := $(BUILD)/bench/peers/bench_states
STATES_OBJ := $(BUILD)/bench/peers/bench_states.o $(BUILD)/bench/peers/fcl_peer.o
$(STATES_BIN): $(STATES_OBJ) $(ALL_LIBS)
	$(CXX) $(OPT) $(SAN) -pthread $(STATES_OBJ) $(ALL_LIBS) $(SYS_LIBS) -lfcl -o $@
DISTANCE_BIN := $(BUILD)/bench/peers/bench_distance
DISTANCE_OBJ := $(BUILD)/bench/peers/bench_distance.o $(BUILD)/bench/peers/fcl_peer.o
$(DISTANCE_BIN): $(DISTANCE_OBJ) $(ALL_LIBS)
	$(CXX) $(OPT) $(SAN) -pthread $(DISTANCE_OBJ) $(ALL_LIBS) $(SYS_LIBS) -lfcl -o $@
.PHONY: bench-distance
bench-distance:
	@sh $(PEER_ENSURE) && $(MAKE) --no-print-directory $(DISTANCE_BIN) && $(DISTANCE_BIN)
$(BUILD)/bench/peers/fcl_peer.o: bench/peers/fcl_peer.cpp | $(DEPS_STAMP)
	@mkdir -p $(dir $@)
	$(CXX) $(PEER_CXXFLAGS) -MMD -MP -c $< -o $@
$(PEER_BIN): $(PEER_OBJ) $(ALL_LIBS)
	$(CXX) $(OPT) $(SAN) -pthread $(PEER_OBJ) $(ALL_LIBS) $(SYS_LIBS) $(PEER_LIBS) -o $@

# Issue 3: what accuracy costs in time. Writes docs/accuracy.md and its plots.
accuracy-report: $(ACC_BIN)
	sh scripts/accuracy_report.sh $(ACC_BIN) $(BUILD)/accuracy

# The README's picture of the demo yard: `trioct render` against the demo daemon, in the
# demo's private namespace (scripts/render_demo.sh).
.PHONY: demo-picture
demo-picture: all $(DEMO_DIR)/.stamp
	sh scripts/render_demo.sh $(BUILD) docs/demo-yard.png

# libtrioct as a shared library (issue 5): position-independent objects of their own, built
# with every symbol hidden but those trioct.h marks TRIOCT_API, so the .so exports the
# public API and nothing else (not the generated wire code, not common/).
PIC_DIR        := $(BUILD)/pic
CLIENT_PIC_OBJ := $(CLIENT_SRC:%.c=$(PIC_DIR)/%.o) $(COMMON_SRC:%.c=$(PIC_DIR)/%.o) \
                  $(GEN_SRC:$(GEN_DIR)/%.c=$(PIC_DIR)/gen/%.o)
CLIENT_SO      := $(BUILD)/libtrioct.so.4
PIC_CFLAGS      = $(ALL_CFLAGS) -fPIC -fvisibility=hidden
$(PIC_DIR)/%.o: %.c | $(DEPS_STAMP) $(GEN_STAMP)
	@mkdir -p $(dir $@)
	$(CC) $(PIC_CFLAGS) -MMD -MP -c $< -o $@
$(PIC_DIR)/gen/%.o: $(GEN_DIR)/%.c
	@mkdir -p $(dir $@)
	$(CC) $(PIC_CFLAGS) -Wno-unused-parameter -c $< -o $@
$(CLIENT_SO): $(CLIENT_PIC_OBJ)
	$(CC) $(ALL_CFLAGS) -shared -Wl,-soname,libtrioct.so.4 -Wl,-z,defs $^ -llcm -lsodium -lm -o $@
# The example docs/client.md walks through, built so that it cannot rot.
EXAMPLE_BIN := $(BUILD)/examples/ray_example
$(EXAMPLE_BIN): $(BUILD)/client/examples/ray_example.o $(CLIENT_LIB)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) $< $(CLIENT_LIB) -llcm -lsodium -lm -o $@
all: $(CLIENT_SO) $(EXAMPLE_BIN)
test: $(CLIENT_SO) $(EXAMPLE_BIN)

# The Python package trioct (docs/python.md): python/trioct/, ctypes over libtrioct.so.4 with
# numpy arrays, built into $(BUILD)/python/trioct/ so that PYTHONPATH=$(BUILD)/python imports
# it: the sources copied, _constants.py generated from the C headers (the status table, the
# caps and the version, typed once) and _paths.py naming the library. _paths.py gives the
# library's path relative to the package first and absolute second, so that a DESTDIR
# staging tree finds its own copy; `make install` writes one for the installed paths.
# PYTHON is the interpreter the tests run: Debian's, which python3-numpy is installed for.
PYTHON      ?= /usr/bin/python3
PY_SRC      := $(wildcard python/trioct/*.py)
PY_BUILD    := $(BUILD)/python/trioct
PY_GEN      := $(PY_BUILD)/_constants.py $(PY_BUILD)/_paths.py
PY_OUT      := $(PY_SRC:python/trioct/%=$(PY_BUILD)/%) $(PY_GEN)
PY_HEADERS  := common/trioct_status.h common/trioct_limits.h common/trioct_version.h
# $(call py_paths,RELATIVE,ABSOLUTE,FILE): writes a _paths.py.
py_paths = printf '"""Where libtrioct is, written by make; do not edit."""\nLIBRARY_RELATIVE = "%s"\nLIBRARY = "%s"\n' \
    '$(1)' '$(2)' > $(3)
$(PY_BUILD)/%.py: python/trioct/%.py
	@mkdir -p $(dir $@)
	cp $< $@
$(PY_BUILD)/_constants.py: python/gen_constants.sh $(PY_HEADERS)
	@mkdir -p $(dir $@)
	sh python/gen_constants.sh $(PY_HEADERS) > $@.tmp && mv $@.tmp $@
$(PY_BUILD)/_paths.py: Makefile
	@mkdir -p $(dir $@)
	$(call py_paths,../../libtrioct.so.4,$(abspath $(BUILD))/libtrioct.so.4,$@)
all: $(PY_OUT)
test: $(PY_OUT)

# Issue 6: replayable message logs (docs/replay.md). trioct-replay feeds an LCM log to a
# fresh trioctd and compares its replies with recorded ones; trioct-make-logs writes the
# request logs of tests/logs, and `make logs` regenerates that directory, golden logs
# included (tools/replay/make_logs.sh). test_replay replays every log at 1 and 4 threads,
# checks the regeneration byte for byte, and runs one live replay inside netns.sh.
REPLAY_BIN    := $(BUILD)/trioct-replay
MAKE_LOGS_BIN := $(BUILD)/trioct-make-logs
REPLAY_LIB    := $(BUILD)/libtrioct_replay.a
REPLAY_OBJ    := $(patsubst %.c,$(BUILD)/%.o,$(filter-out tools/replay/replay_main.c,$(wildcard tools/replay/replay_*.c)))
MAKE_LOGS_OBJ := $(patsubst %.c,$(BUILD)/%.o,tools/replay/make_logs.c $(wildcard tools/replay/logs_*.c))
$(REPLAY_LIB): $(REPLAY_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(REPLAY_BIN): $(BUILD)/tools/replay/replay_main.o $(REPLAY_LIB) $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(REPLAY_LIB) $(ALL_LIBS) $(SYS_LIBS) -o $@
$(MAKE_LOGS_BIN): $(MAKE_LOGS_OBJ) $(REPLAY_LIB) $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $(MAKE_LOGS_OBJ) $(REPLAY_LIB) $(ALL_LIBS) $(SYS_LIBS) -o $@
$(BUILD)/tests/test_replay: $(BUILD)/tests/test_replay.o $(REPLAY_LIB) $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(REPLAY_LIB) $(ALL_LIBS) -lcmocka $(SYS_LIBS) -o $@
all test: $(REPLAY_BIN) $(MAKE_LOGS_BIN)
.PHONY: logs
logs: $(MAKE_LOGS_BIN) $(REPLAY_BIN) $(DAEMON_BIN)
	sh tools/replay/make_logs.sh $(BUILD) tests/logs

# Java types for lcm-spy and Java programs (docs/protocol.md, "Watching the bus with lcm-spy"):
# lcm-gen -j turns proto/*.lcm into Java (package trioct) in $(BUILD)/java/src, javac
# compiles it against Debian's lcm.jar (liblcm-java) for Java 8 bytecode, as lcm.jar's own,
# and $(JAVA_JAR) packs the classes; generated, never committed. `make java` builds it,
# installing a JDK and liblcm-java when they are missing (as root; otherwise
# scripts/deps.sh prints the apt-get line and it fails). `all` builds it only when javac,
# jar and lcm.jar are all there already, and so does `make install`, which installs it
# when it is built. scripts/lcm-spy runs lcm-spy with it. tests/java/java_test.sh checks
# the jar against proto/ and decodes C-encoded messages and tests/logs with it.
LCM_JAR    ?= /usr/share/java/lcm.jar
JAVAC      ?= javac
JAR        ?= jar
JAVA_DIR   := $(BUILD)/java
JAVA_JAR   := $(BUILD)/trioct-lcm-types.jar
JAVA_FOUND := $(and $(shell command -v $(JAVAC) 2>/dev/null),$(shell command -v $(JAR) 2>/dev/null),$(wildcard $(LCM_JAR)))
JAVA_FIXTURE_BIN := $(BUILD)/tests/java/fixture_log
.PHONY: java java-deps install-java
java: $(JAVA_JAR)
java-deps:
	@missing=; command -v $(JAVAC) >/dev/null 2>&1 && command -v $(JAR) >/dev/null 2>&1 || missing=default-jdk-headless; \
	[ -r $(LCM_JAR) ] || missing="$$missing liblcm-java"; \
	[ -z "$$missing" ] || sh scripts/deps.sh $$missing
$(JAVA_JAR): $(PROTO) | $(DEPS_STAMP) java-deps
	rm -rf $(JAVA_DIR) && mkdir -p $(JAVA_DIR)/src $(JAVA_DIR)/classes
	lcm-gen -j --jpath $(JAVA_DIR)/src $(PROTO)
	$(JAVAC) --release 8 -Xlint:-options -cp $(LCM_JAR) -d $(JAVA_DIR)/classes $(JAVA_DIR)/src/trioct/*.java
	rm -f $@ && $(JAR) cf $@ -C $(JAVA_DIR)/classes trioct
all: $(if $(JAVA_FOUND),$(JAVA_JAR))
# The C half of the Java test: a log of messages the generated C code encodes.
$(JAVA_FIXTURE_BIN): $(BUILD)/tests/java/fixture_log.o $(PROTO_LIB)
	$(CC) $(ALL_CFLAGS) $< $(PROTO_LIB) -llcm $(LDLIBS_ENGINE) -o $@
test: $(JAVA_FIXTURE_BIN)

# ---- make install, make uninstall ----------------------------------------------------------
# Laid out as a Debian package would be, every directory a variable (on the command line:
# `make install PREFIX=/usr LIBDIR=/usr/lib/x86_64-linux-gnu DESTDIR=...`), and what is read
# at run time (trioct.pc, the Python package's _paths.py, the unit's ExecStart) written for
# the final place, not the DESTDIR staging one:
#   PREFIX            /usr/local
#   BINDIR            $(PREFIX)/bin: trioctd, trioct, trioct-replay
#   LIBDIR            $(PREFIX)/lib: libtrioct.a, libtrioct.so.4 and its .so link, and
#                     pkgconfig/trioct.pc; a multiarch directory works the same
#   INCLUDEDIR        $(PREFIX)/include: trioct/trioct.h and the two headers it includes
#   MAN_DIR           $(PREFIX)/share/man: trioct(1), trioct-replay(1), trioctd(8)
#   PYTHONDIR         $(PREFIX)/lib/python3/dist-packages: the trioct Python package (on
#                     Debian's sys.path for PREFIX=/usr; for /usr/local, Debian's python3
#                     reads /usr/local/lib/python3.X/dist-packages instead)
#   SYSTEMD_UNIT_DIR  $(PREFIX)/lib/systemd/system, which systemd reads for /usr and
#                     /usr/local alike
#   JAVADIR           $(PREFIX)/share/java: trioct-lcm-types.jar, when it is built (`make java`)
# trioct-load goes to $(PREFIX)/libexec/trioct/, where trioctd looks for it (../libexec/trioct/
# from its own directory). tests/e2e/install_test.sh checks the tree file by file, and that
# `make uninstall` with the same variables leaves no file behind.
PREFIX     ?= /usr/local
BINDIR      = $(PREFIX)/bin
LIBDIR      = $(PREFIX)/lib
INCLUDEDIR  = $(PREFIX)/include
LOADER_DIR  = $(PREFIX)/libexec/trioct
MAN_DIR    ?= $(PREFIX)/share/man
PYTHONDIR  ?= $(PREFIX)/lib/python3/dist-packages
JAVADIR    ?= $(PREFIX)/share/java
SYSTEMD_UNIT_DIR ?= $(PREFIX)/lib/systemd/system
PC_VERSION := $(or $(shell sed -n 's/^\#define TRIOCT_VERSION "\(.*\)"/\1/p' common/trioct_version.h),0)
PUBLIC_HEADERS := client/trioct.h common/trioct_limits.h common/trioct_status.h
MAN_PAGES  := man1/trioct.1 man1/trioct-replay.1 man8/trioctd.8
PY_INSTALLED := $(notdir $(PY_OUT))
.PHONY: install install-lib install-python install-service uninstall
install: install-lib install-python install-service install-java

# The programs, both libraries, the header with the two it includes (in include/trioct/,
# where its quoted includes find them) and trioct.pc. Its Cflags name include/ and
# include/trioct/, so <trioct/trioct.h> and "trioct.h" both work.
install-lib: $(DAEMON_BIN) $(LOADER_BIN) $(REPLAY_BIN) $(CLIENT_LIB) $(CLIENT_SO) $(if $(wildcard client/cli/*.c),$(BUILD)/trioct)
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(INCLUDEDIR)/trioct $(DESTDIR)$(LOADER_DIR)
	install -m 0755 $(DAEMON_BIN) $(DESTDIR)$(BINDIR)/trioctd
	install -m 0755 $(LOADER_BIN) $(DESTDIR)$(LOADER_DIR)/trioct-load
	if [ -f $(BUILD)/trioct ]; then install -m 0755 $(BUILD)/trioct $(DESTDIR)$(BINDIR)/trioct; fi
	install -m 0755 $(REPLAY_BIN) $(DESTDIR)$(BINDIR)/trioct-replay
	install -m 0644 $(CLIENT_LIB) $(DESTDIR)$(LIBDIR)/libtrioct.a
	install -m 0644 $(CLIENT_SO) $(DESTDIR)$(LIBDIR)/libtrioct.so.4
	ln -sf libtrioct.so.4 $(DESTDIR)$(LIBDIR)/libtrioct.so
	install -m 0644 $(PUBLIC_HEADERS) $(DESTDIR)$(INCLUDEDIR)/trioct/
	sed -e 's|@PREFIX@|$(PREFIX)|g' -e 's|@LIBDIR@|$(LIBDIR)|g' -e 's|@INCLUDEDIR@|$(INCLUDEDIR)|g' \
	    -e 's|@VERSION@|$(PC_VERSION)|g' client/trioct.pc.in > $(DESTDIR)$(LIBDIR)/pkgconfig/trioct.pc
	chmod 0644 $(DESTDIR)$(LIBDIR)/pkgconfig/trioct.pc

# The Python package, its _paths.py naming the installed library: relative to the package
# first, so that it is found in a DESTDIR staging tree too, then by its absolute path.
install-python: $(PY_OUT)
	install -d $(DESTDIR)$(PYTHONDIR)/trioct
	install -m 0644 $(filter-out %/_paths.py,$(PY_OUT)) $(DESTDIR)$(PYTHONDIR)/trioct/
	$(call py_paths,$(shell realpath -m -s --relative-to=$(PYTHONDIR)/trioct $(LIBDIR))/libtrioct.so.4,$(LIBDIR)/libtrioct.so.4,$(DESTDIR)$(PYTHONDIR)/trioct/_paths.py)
	chmod 0644 $(DESTDIR)$(PYTHONDIR)/trioct/_paths.py

# Issue 7: the systemd unit, the example scene and the man pages. The unit's ExecStart
# points at $(BINDIR)/trioctd. The scene goes to /etc/trioct, where the unit reads it
# whatever the prefix, and only when none is there: a reinstall never overwrites an edited
# one. A pristine copy goes to share/trioct always.
install-service:
	install -d $(DESTDIR)$(SYSTEMD_UNIT_DIR) $(DESTDIR)/etc/trioct/worlds \
	    $(DESTDIR)$(PREFIX)/share/trioct $(DESTDIR)$(MAN_DIR)/man1 $(DESTDIR)$(MAN_DIR)/man8
	sed 's|^ExecStart=/usr/bin/trioctd |ExecStart=$(BINDIR)/trioctd |' systemd/trioctd.service \
	    > $(DESTDIR)$(SYSTEMD_UNIT_DIR)/trioctd.service
	chmod 0644 $(DESTDIR)$(SYSTEMD_UNIT_DIR)/trioctd.service
	install -m 0644 systemd/scene.ini $(DESTDIR)$(PREFIX)/share/trioct/scene.ini.example
	test -e $(DESTDIR)/etc/trioct/scene.ini || \
	    install -m 0644 systemd/scene.ini $(DESTDIR)/etc/trioct/scene.ini
	for page in $(MAN_PAGES); do install -m 0644 man/$${page#*/} $(DESTDIR)$(MAN_DIR)/$$page || exit 1; done

# The Java types jar (see `make java`), built first when a JDK and lcm.jar are there; a
# machine without them installs no jar, as `all` built none.
install-java: $(if $(JAVA_FOUND),$(JAVA_JAR))
	if [ -f $(JAVA_JAR) ]; then install -d $(DESTDIR)$(JAVADIR) && \
	    install -m 0644 $(JAVA_JAR) $(DESTDIR)$(JAVADIR)/trioct-lcm-types.jar; fi

# Removes what install put there, with the same variables, and the directories it made under
# trioct's own names once they are empty; shared directories (bin, lib, share/man, ...) stay.
# /etc/trioct/scene.ini goes only when it is still the shipped scene: an edited one is the
# administrator's and is kept (as dpkg keeps a changed conffile), and so is its directory.
# The Python package's byte code, written when it was first imported, goes with it.
uninstall:
	@scene=$(DESTDIR)/etc/trioct/scene.ini; \
	if cmp -s systemd/scene.ini $$scene || cmp -s $(DESTDIR)$(PREFIX)/share/trioct/scene.ini.example $$scene; then \
	    echo "rm -f $$scene"; rm -f $$scene; \
	elif [ -e $$scene ]; then echo "uninstall: kept $$scene: it was edited"; fi
	rm -f $(addprefix $(DESTDIR)$(BINDIR)/,trioctd trioct trioct-replay) $(DESTDIR)$(LOADER_DIR)/trioct-load \
	    $(addprefix $(DESTDIR)$(LIBDIR)/,libtrioct.a libtrioct.so.4 libtrioct.so pkgconfig/trioct.pc) \
	    $(addprefix $(DESTDIR)$(INCLUDEDIR)/trioct/,$(notdir $(PUBLIC_HEADERS))) \
	    $(addprefix $(DESTDIR)$(MAN_DIR)/,$(MAN_PAGES)) \
	    $(DESTDIR)$(SYSTEMD_UNIT_DIR)/trioctd.service $(DESTDIR)$(PREFIX)/share/trioct/scene.ini.example \
	    $(DESTDIR)$(JAVADIR)/trioct-lcm-types.jar \
	    $(addprefix $(DESTDIR)$(PYTHONDIR)/trioct/,$(PY_INSTALLED))
	rm -f $(foreach f,$(basename $(PY_INSTALLED)),$(DESTDIR)$(PYTHONDIR)/trioct/__pycache__/$(f).*.pyc)
	for d in $(DESTDIR)$(INCLUDEDIR)/trioct $(DESTDIR)$(LOADER_DIR) $(DESTDIR)$(PREFIX)/share/trioct \
	    $(DESTDIR)$(PYTHONDIR)/trioct/__pycache__ $(DESTDIR)$(PYTHONDIR)/trioct \
	    $(DESTDIR)/etc/trioct/worlds $(DESTDIR)/etc/trioct; do \
	    if [ -d $$d ]; then rmdir --ignore-fail-on-non-empty $$d || exit 1; fi; done

clean:
	rm -rf build build-asan

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)

# Issue 20: fuzzing with libFuzzer (clang, ASan + UBSan). `make fuzz` installs clang and its
# fuzzer runtime when they are missing (as root), builds every target into build-fuzz/ and
# runs each for FUZZ_SECONDS (default 60) from seed corpora made of tests/logs' requests and
# mesh files (scripts/run_fuzz.sh). One target per request type's bytes-to-reply path, one
# for the loader child's parsing, one for what the daemon reads back from the child.
FUZZ_BUILD    := build-fuzz
FUZZ_SECONDS  ?= 60
FUZZ_REQUESTS := ray triangle mesh admin objects state distance
FUZZ_TARGETS  := $(FUZZ_REQUESTS:%=fuzz_%) fuzz_mesh_file fuzz_mesh_frame
FUZZ_LIBS     := $(SERVICE_LIB) $(WORLD_LIB) $(PROTO_LIB) $(ENGINE_LIB)
.PHONY: fuzz fuzz-build
fuzz:
	sh scripts/deps.sh clang libclang-rt-dev
	$(MAKE) BUILD=$(FUZZ_BUILD) CC=clang OPT="-O1 -g -fno-omit-frame-pointer" \
	    SAN="-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=all" fuzz-build
	sh scripts/run_fuzz.sh $(FUZZ_BUILD) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

fuzz-build: $(FUZZ_TARGETS:%=$(BUILD)/fuzz/%) $(BUILD)/fuzz/make_corpus $(LOADER_BIN)
$(BUILD)/fuzz/%.o: CFLAGS += -Itools/replay
$(BUILD)/fuzz/request_%.o: fuzz/fuzz_request.c | $(DEPS_STAMP) $(GEN_STAMP)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -Itools/replay -DFUZZ_TYPE=REQUEST_$(shell echo $* | tr a-z A-Z) -MMD -MP -c $< -o $@
$(FUZZ_REQUESTS:%=$(BUILD)/fuzz/fuzz_%): $(BUILD)/fuzz/fuzz_%: $(BUILD)/fuzz/request_%.o $(FUZZ_LIBS)
	$(CC) $(ALL_CFLAGS) -fsanitize=fuzzer $< $(FUZZ_LIBS) $(SYS_LIBS) -o $@
$(BUILD)/fuzz/fuzz_mesh_file $(BUILD)/fuzz/fuzz_mesh_frame: $(BUILD)/fuzz/%: $(BUILD)/fuzz/%.o $(WORLD_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) -fsanitize=fuzzer $< $(WORLD_LIB) $(ENGINE_LIB) -lassimp $(LDLIBS_ENGINE) -o $@
$(BUILD)/fuzz/make_corpus: $(BUILD)/fuzz/make_corpus.o $(REPLAY_LIB) $(PROTO_LIB)
	$(CC) $(ALL_CFLAGS) $< $(REPLAY_LIB) $(PROTO_LIB) -llcm $(LDLIBS_ENGINE) -o $@
