# trioct build. `make` builds, `make test` runs every test, `make asan` runs them under
# AddressSanitizer + UndefinedBehaviorSanitizer, `make bench` prints the benchmarks.

CC      ?= cc
BUILD   ?= build
OPT     ?= -O2 -g
# -ffp-contract=off: the predicates' error bounds assume every operation is rounded on its
# own; a fused multiply-add would change the arithmetic under them.
CFLAGS_BASE = -std=c11 -D_POSIX_C_SOURCE=200809L -Wall -Wextra -Werror -ffp-contract=off \
              -fno-strict-aliasing -Iserver -Itests -pthread
CFLAGS  ?=
ALL_CFLAGS = $(CFLAGS_BASE) $(OPT) $(SAN) $(CFLAGS)
LDLIBS_ENGINE = -lm -pthread

ENGINE_SRC := $(wildcard server/geom/*.c server/octree/*.c)
WORLD_SRC  := $(wildcard server/world/*.c)
SUPPORT_SRC := $(wildcard tests/support/*.c)
TEST_SRC   := $(wildcard tests/test_*.c)
BENCH_SRC  := $(wildcard bench/bench_*.c)
DEMO_BIN   := $(BUILD)/trioct-demo
ACC_BIN    := $(BUILD)/bench/report_accuracy

ENGINE_OBJ  := $(ENGINE_SRC:%.c=$(BUILD)/%.o)
WORLD_OBJ   := $(WORLD_SRC:%.c=$(BUILD)/%.o)
SUPPORT_OBJ := $(SUPPORT_SRC:%.c=$(BUILD)/%.o)
TEST_BIN    := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)
BENCH_BIN   := $(BENCH_SRC:bench/%.c=$(BUILD)/bench/%)

ENGINE_LIB  := $(BUILD)/libtrioct_engine.a
WORLD_LIB   := $(BUILD)/libtrioct_world.a
SUPPORT_LIB := $(BUILD)/libtestsupport.a
DEPS_STAMP  := $(BUILD)/.deps-ok

.PHONY: all deps test asan bench run clean accuracy-report
all: $(ENGINE_LIB) $(WORLD_LIB) $(TEST_BIN) $(BENCH_BIN) $(DEMO_BIN)

deps: $(DEPS_STAMP)
$(DEPS_STAMP): scripts/deps.sh
	@mkdir -p $(BUILD)
	@sh scripts/deps.sh
	@touch $@

$(BUILD)/%.o: %.c | $(DEPS_STAMP)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -MMD -MP -c $< -o $@

$(ENGINE_LIB): $(ENGINE_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(WORLD_LIB): $(WORLD_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^
$(SUPPORT_LIB): $(SUPPORT_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^

TEST_LIBS = $(SUPPORT_LIB) $(WORLD_LIB) $(ENGINE_LIB) -lcmocka -lgmp -lassimp $(LDLIBS_ENGINE)
$(BUILD)/tests/%: $(BUILD)/tests/%.o $(SUPPORT_LIB) $(WORLD_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) $< $(TEST_LIBS) -o $@

BENCH_LIBS = $(SUPPORT_LIB) $(WORLD_LIB) $(ENGINE_LIB) -lgmp -lassimp $(LDLIBS_ENGINE)
$(BUILD)/bench/%: $(BUILD)/bench/%.o $(SUPPORT_LIB) $(WORLD_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) $< $(BENCH_LIBS) -o $@

$(ACC_BIN): $(BUILD)/bench/report_accuracy.o $(SUPPORT_LIB) $(WORLD_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) $< $(BENCH_LIBS) -o $@

$(DEMO_BIN): $(BUILD)/tools/trioct_demo.o $(SUPPORT_LIB) $(WORLD_LIB) $(ENGINE_LIB)
	$(CC) $(ALL_CFLAGS) $< $(BENCH_LIBS) -o $@

# Until the daemon exists (issue 4), run shows the engine on a real and a generated mesh.
run: $(DEMO_BIN)
	$(DEMO_BIN)

# Every test binary runs even when one fails; the target fails if any did.
test: $(TEST_BIN)
	@export LCM_DEFAULT_URL=memq://; fail=0; \
	for t in $(TEST_BIN); do echo "== $$t"; $$t || fail=1; done; \
	if [ $$fail -ne 0 ]; then echo "make test: FAILED"; exit 1; fi; echo "make test: all test programs passed"

asan:
	$(MAKE) BUILD=build-asan OPT="-O1 -g -fno-omit-frame-pointer" \
	    SAN="-fsanitize=address,undefined -fno-sanitize-recover=all" test

bench: $(BENCH_BIN)
	@for b in $(BENCH_BIN); do echo "== $$b"; $$b || exit 1; done

# Issue 3: what accuracy costs in time. Writes docs/accuracy.md and its plots.
accuracy-report: $(ACC_BIN)
	sh scripts/accuracy_report.sh $(ACC_BIN) $(BUILD)/accuracy

clean:
	rm -rf build build-asan

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
