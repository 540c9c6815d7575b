# infilld - one non-recursive Makefile.  See README.md.
#
#   make run          install missing Debian packages, build, start the service
#   make test         install, build, run every test (unit, CLI, service, fuzz smoke)
#   make bench        benchmarks with printed figures (not part of test)
#   make deps         install the Debian packages (idempotent, quick when present)
#   make SANITIZE=1 test   the same under ASan + UBSan (separate build dir)
#
# Sources are discovered: engine/**.c|cpp -> libengine.a, api/*.c -> libapi.a,
# db/**.c -> libdb.a, service/*.c -> the infilld binary; every
# tests/unit/<module>/test_*.c is its own test program.

.SUFFIXES:
.DELETE_ON_ERROR:
SHELL := /bin/bash

SANITIZE ?= 0
BUILD := build$(if $(filter 1,$(SANITIZE)),-san)
CC := gcc
CXX := g++
NPROC := $(shell nproc 2>/dev/null || echo 2)

PKGS := libpng zlib libarchive jansson libmicrohttpd sqlite3 nettle polyclipping ipopt
# Evaluated lazily: pkg-config only runs once the packages are installed.
PKG_CFLAGS = $(shell pkg-config --cflags $(PKGS) 2>/dev/null)
PKG_LIBS = $(shell pkg-config --libs $(PKGS) 2>/dev/null) -ltet

WARN := -Wall -Wextra -Werror -Wshadow -Wundef -Wwrite-strings -Wmissing-prototypes \
	-Wstrict-prototypes -Wold-style-definition -Wpointer-arith -Wformat=2 -Wvla \
	-Wmissing-declarations -Wredundant-decls -Wno-format-truncation
# -Wno-format-truncation: messages are bounded on purpose (err.h, sink_printf).
OPT := $(if $(filter 1,$(SANITIZE)),-O1,-O2)
SANFLAGS := -fsanitize=address -fsanitize=undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
SAN := $(if $(filter 1,$(SANITIZE)),$(SANFLAGS))
DEFS := -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE

CFLAGS = -std=c11 $(OPT) -g $(WARN) $(DEFS) $(SAN) -pthread -MMD -MP -I. $(PKG_CFLAGS)
CXXFLAGS = -std=c++14 $(OPT) -g -Wall -Wextra -Werror $(SAN) -pthread -MMD -MP -I. \
	-isystem /usr/include/polyclipping -isystem /usr/include/coin -DTETLIBRARY
LDFLAGS = $(SAN) -pthread
LDLIBS = $(PKG_LIBS) -lm -lstdc++

ENGINE_SRC := $(shell find engine -name '*.c' -o -name '*.cpp' | sort)
API_SRC := $(sort $(wildcard api/*.c))
DB_SRC := $(shell find db -name '*.c' | sort)
SERVICE_SRC := $(sort $(wildcard service/*.c))
UNIT_SRC := $(sort $(wildcard tests/unit/*/test_*.c))
TEST_SUPPORT_SRC := $(sort $(wildcard tests/support/*.c))

obj = $(patsubst %,$(BUILD)/obj/%.o,$(1))
ENGINE_OBJ := $(call obj,$(ENGINE_SRC))
API_OBJ := $(call obj,$(API_SRC))
DB_OBJ := $(call obj,$(DB_SRC))
SERVICE_OBJ := $(call obj,$(SERVICE_SRC))
TEST_SUPPORT_OBJ := $(call obj,$(TEST_SUPPORT_SRC))
UNIT_BIN := $(patsubst tests/unit/%.c,$(BUILD)/tests/unit/%,$(UNIT_SRC))
BENCH_SRC := $(sort $(wildcard tests/bench/bench_*.c))
BENCH_BIN := $(patsubst tests/bench/%.c,$(BUILD)/tests/bench/%,$(BENCH_SRC))

# The portal's files (web/), compiled into libapi.a by web/embed.sh so the
# binary serves them wherever it runs; three.js is vendored under
# web/vendor/ (from npm, committed), so building needs no npm.
WEB_SRC := $(sort $(wildcard web/*.html web/*.js web/*.css)) web/vendor/three.module.min.js
WEB_GEN := $(BUILD)/gen/web_files.c
WEB_OBJ := $(BUILD)/obj/api/web_files.gen.c.o

LIBS := $(BUILD)/libapi.a $(BUILD)/libdb.a $(BUILD)/libengine.a
BIN := $(BUILD)/infilld

.PHONY: all deps build units benches run test check test-unit bench bench-large fuzz check-style clean
all: build

deps:
	@deploy/deps.sh

build: $(BIN) $(UNIT_BIN) $(BENCH_BIN)

# V=1 shows the full commands.
Q := $(if $(filter 1,$(V)),,@)
$(BUILD)/obj/%.c.o: %.c
	@mkdir -p $(@D)
	@$(if $(Q),echo "  CC      $<")
	$(Q)$(CC) $(CFLAGS) -c $< -o $@

$(BUILD)/obj/%.cpp.o: %.cpp
	@mkdir -p $(@D)
	@$(if $(Q),echo "  CXX     $<")
	$(Q)$(CXX) $(CXXFLAGS) -c $< -o $@

$(BUILD)/libengine.a: $(ENGINE_OBJ)
	@mkdir -p $(@D)
	$(Q)rm -f $@ && ar rcs $@ $^
$(WEB_GEN): $(WEB_SRC) web/embed.sh
	@$(if $(Q),echo "  EMBED   web/ -> $@")
	$(Q)web/embed.sh $@ $(WEB_SRC)
$(WEB_OBJ): $(WEB_GEN)
	@mkdir -p $(@D)
	@$(if $(Q),echo "  CC      $<")
	$(Q)$(CC) $(CFLAGS) -c $< -o $@

$(BUILD)/libapi.a: $(API_OBJ) $(WEB_OBJ)
	@mkdir -p $(@D)
	$(Q)rm -f $@ && ar rcs $@ $^
$(BUILD)/libdb.a: $(DB_OBJ)
	@mkdir -p $(@D)
	$(Q)rm -f $@ && ar rcs $@ $^

$(BIN): $(SERVICE_OBJ) $(LIBS)
	@$(if $(Q),echo "  LINK    $@")
	$(Q)$(CXX) $(LDFLAGS) -o $@ $(SERVICE_OBJ) $(LIBS) $(LDLIBS)

$(BUILD)/tests/unit/%: tests/unit/%.c $(TEST_SUPPORT_OBJ) $(LIBS)
	@mkdir -p $(@D)
	@$(if $(Q),echo "  TEST    $<")
	$(Q)$(CC) $(CFLAGS) -Itests -c $< -o $@.o
	$(Q)$(CXX) $(LDFLAGS) -o $@ $@.o $(TEST_SUPPORT_OBJ) $(LIBS) $(LDLIBS)

$(BUILD)/tests/bench/%: tests/bench/%.c $(LIBS)
	@mkdir -p $(@D)
	@$(if $(Q),echo "  BENCH   $<")
	$(Q)$(CC) $(CFLAGS) -Itests -c $< -o $@.o
	$(Q)$(CXX) $(LDFLAGS) -o $@ $@.o $(LIBS) $(LDLIBS)

# The README's two commands.  `make run` needs neither npm nor its registry
# (SKIP_NPM=1): only the tests run the OpenAPI linter.
run:
	@SKIP_NPM=1 deploy/deps.sh
	@$(MAKE) --no-print-directory build
	@deploy/run-dev.sh $(BIN)

test: deps
	@$(MAKE) --no-print-directory -j$(NPROC) build
	@$(MAKE) --no-print-directory fuzz-build
	@tests/run.sh $(BUILD) $(if $(filter 1,$(SANITIZE)),sanitize)

# Only the unit tests (fast inner loop while developing).
units: $(UNIT_BIN)
benches: $(BENCH_BIN)
test-unit: units
	@tests/run.sh $(BUILD) $(if $(filter 1,$(SANITIZE)),sanitize) unit

# Fuzz targets (clang + libFuzzer); `make fuzz FUZZ_SECONDS=600` for a long run.
FUZZ_SRC := $(sort $(wildcard tests/fuzz/fuzz_*.c))
FUZZ_BIN := $(patsubst tests/fuzz/%.c,build-fuzz/%,$(FUZZ_SRC))
FUZZ_ENGINE_SRC = $(filter-out %.cpp,$(ENGINE_SRC))
FUZZ_SECONDS ?= 60
# The lattice engine's parsers (lattice files, NRRD density grids) and what they need.
FUZZ_LATTICE_SRC := engine/lattice/graph.c engine/lattice/file_bin.c engine/lattice/file_text.c \
	engine/lattice/density.c
# The G-code layer preview reader and what it needs (libpng for its PNG).
FUZZ_GCODE_SRC := engine/output/gcode/gcode_preview.c engine/output/image/png_encode.c \
	engine/output/toolpath/plan.c
.PHONY: fuzz-build
fuzz-build: $(FUZZ_BIN)
build-fuzz/%: tests/fuzz/%.c $(wildcard tests/fuzz/*.h engine/*/*.h) $(ENGINE_SRC)
	@mkdir -p $(@D)
	@$(if $(Q),echo "  FUZZ    $<")
	$(Q)clang -std=c11 -O1 -g -fsanitize=fuzzer,address,undefined $(DEFS) -I. $(PKG_CFLAGS) \
		-Wall -Wextra -Werror -o $@ $< $(filter engine/core/% engine/geom/%.c engine/mesh/% $(FUZZ_LATTICE_SRC) $(FUZZ_GCODE_SRC),$(FUZZ_ENGINE_SRC)) \
		$(shell pkg-config --libs libpng zlib 2>/dev/null) -lm
fuzz: deps
	@$(MAKE) --no-print-directory fuzz-build
	@tests/fuzz/run.sh $(FUZZ_SECONDS)

bench: deps
	@$(MAKE) --no-print-directory -j$(NPROC) build
	@tests/bench/run.sh $(BUILD)

# The mesh benchmark alone (also run by `make bench` via tests/bench/bench_mesh.sh).
.PHONY: bench-mesh
bench-mesh: $(BUILD)/tests/bench/bench_mesh
	$< $(if $(INFILLD_SHARED),$(INFILLD_SHARED),../shared)

bench-large: deps
	@$(MAKE) --no-print-directory -j$(NPROC) build
	@tests/bench/run.sh $(BUILD) large

check-style:
	@tests/check-style.sh $(BUILD)

clean:
	rm -rf build build-san build-fuzz

-include $(shell find $(BUILD) build-fuzz -name '*.d' 2>/dev/null)
