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
# lcm-gen's C has unused parameters; only its warnings are relaxed.
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
SYS_LIBS = -lgmp -lassimp -llcm -luv -linih $(LDLIBS_ENGINE)
$(BUILD)/tests/%: $(BUILD)/tests/%.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) -lcmocka $(SYS_LIBS) -o $@

# End to end over udpm, inside a private network namespace (tests/e2e/netns.sh).
E2E_BIN := $(BUILD)/tests/e2e_daemon
$(E2E_BIN): $(BUILD)/tests/e2e/e2e_daemon.o $(ALL_LIBS)
	$(CC) $(ALL_CFLAGS) $< $(ALL_LIBS) -lcmocka $(SYS_LIBS) -o $@

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

$(DAEMON_BIN): $(BUILD)/server/service/trioctd.o $(SERVICE_LIB) $(WORLD_LIB) $(PROTO_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) $< $(SERVICE_LIB) $(WORLD_LIB) $(PROTO_LIB) $(ENGINE_LIB) $(SYS_LIBS) -o $@

# The daemon on the demo scene, in a private network namespace, after a demo client's questions.
run: $(DAEMON_BIN) $(DEMO_BIN) $(DEMO_DIR)/.stamp
	sh scripts/run_demo.sh $(BUILD)

# Every test binary runs even when one fails; the target fails if any did.
# The end-to-end run needs root for its namespace; without it, it says so and is skipped.
test: $(TEST_BIN) $(E2E_BIN) $(DAEMON_BIN)
	@export LCM_DEFAULT_URL=memq://; fail=0; \
	for t in $(TEST_BIN); do echo "== $$t"; $$t || fail=1; done; \
	echo "== $(E2E_BIN) (udpm in a private network namespace)"; \
	tests/e2e/netns.sh $(E2E_BIN) $(DAEMON_BIN); rc=$$?; \
	if [ $$rc -eq 77 ]; then echo "SKIPPED: end-to-end tests need root"; elif [ $$rc -ne 0 ]; then fail=1; fi; \
	if [ $$fail -ne 0 ]; then echo "make test: FAILED"; exit 1; fi; echo "make test: all test programs passed"

asan:
	$(MAKE) BUILD=build-asan OPT="-O1 -g -fno-omit-frame-pointer" \
	    SAN="-fsanitize=address,undefined -fno-sanitize-recover=all" test

bench: $(BENCH_BIN) $(DAEMON_BENCH_BIN) $(DAEMON_BIN)
	@for b in $(BENCH_BIN); do echo "== $$b"; $$b || exit 1; done
	@echo "== $(DAEMON_BENCH_BIN) (udpm in a private network namespace)"
	tests/e2e/netns.sh $(DAEMON_BENCH_BIN) $(DAEMON_BIN)

# Issue 3: what accuracy costs in time. Writes docs/accuracy.md and its plots.
accuracy-report: $(ACC_BIN)
	sh scripts/accuracy_report.sh $(ACC_BIN) $(BUILD)/accuracy

clean:
	rm -rf build build-asan

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
