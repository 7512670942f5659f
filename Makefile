# formfactor: the README's two set-up commands, `make run` and `make test`, on a fresh Debian 12.
# Each installs the Debian packages that are missing (apt-get, only when something is missing),
# configures and builds Release into build/, then runs the main job or every test.
# The machines that look for bugs (CI runs them, .ci/run): `make test-sanitize` (ASan + UBSan,
# build-sanitize/), `make test-tsan` (ThreadSanitizer on the concurrency tests, build-tsan/),
# `make fuzz` (libFuzzer, the same clang tree, FUZZ_SECONDS per target), `make format-check`.

BUILD_DIR ?= build
JOBS ?= 2
CMAKE_FLAGS ?=
SANITIZE_DIR ?= build-sanitize
TSAN_DIR ?= build-tsan
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?=
# ccache when the machine has it (it is not a dependency).
LAUNCHER := $(if $(shell command -v ccache),-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

DEB_PACKAGES := cmake g++ make pkg-config \
	libembree-dev libtbb-dev libeigen3-dev libcli11-dev nlohmann-json3-dev libfmt-dev \
	libtinyobjloader-dev libstb-dev libhdf5-dev zlib1g-dev doctest-dev libbenchmark-dev pybind11-dev \
	python3-dev python3-numpy python3-scipy python3-pytest python3-matplotlib python3-h5py \
	python3-setuptools python3-wheel python3-pip python3-venv mypy \
	clang libclang-rt-14-dev clang-format chromium \
	gmsh libassimp-dev \
	openmpi-bin libopenmpi-dev python3-mpi4py
# node and npm bundle the result page (web/) at build time; a machine with its own node (e.g.
# NodeSource's, which carries npm) keeps it.
DEB_PACKAGES += $(if $(shell command -v npm),,nodejs npm)

SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps configure build run test bench format format-check clean \
	test-sanitize test-tsan fuzz fuzz-build sanitize-configure

all: build

deps:
	@missing=$$(for p in $(DEB_PACKAGES); do \
		dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; \
	done); \
	if [ -n "$$missing" ]; then \
		echo "Installing missing Debian packages:" $$missing; \
		$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get update -q && \
		$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $$missing; \
	fi

configure: deps
	@if [ ! -f $(BUILD_DIR)/CMakeCache.txt ]; then \
		cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS); \
	fi

build: configure
	cmake --build $(BUILD_DIR) -j$(JOBS)

run: build
	./$(BUILD_DIR)/bin/formfactor run

test: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j$(JOBS)

bench: build
	@for b in $(BUILD_DIR)/bench/bench_*; do echo "== $$b"; $$b; done

# AddressSanitizer + UndefinedBehaviorSanitizer on the library, the CLI and the whole suite except
# the `slow` label (they take minutes even unsanitized). Any report fails the run.
# One clang tree serves the sanitized suite and the fuzzers: -O1 with line tables only compiles
# about five times faster than GCC's -O2 -g under ASan + UBSan (measured: 14 s against 67 s for
# the largest file), and the library is built once for both.
SANITIZE_FLAGS := -DCMAKE_BUILD_TYPE=Sanitize \
	-DCMAKE_CXX_FLAGS_SANITIZE="-O1 -gline-tables-only" -DCMAKE_C_FLAGS_SANITIZE="-O1" \
	-DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
	-DFF_SANITIZE=address,undefined -DFF_BUILD_FUZZ=ON -DFF_BUILD_BENCH=OFF

# Left out of the sanitized run (they run unsanitized in `make test`): the slow label, and the
# integration-heavy cases that take 4–25 min each under ASan at -O1 on two cores (measured:
# the differential fast slice 1,500 s, room n = 8 455 s, the 1000-gon disks 240 s).
# The mpi label too: LeakSanitizer reports Open MPI's own allocations at MPI_Finalize as leaks
# (a two-line MPI program under mpirun fails alike); the ranks' messages are tested without MPI.
SANITIZE_SKIP_LABELS ?= slow|obstructed-references|mpi
# The golden outputs are byte-exact for the Release toolchain (GCC), not for clang at -O1. The
# CLI's hierarchical solves against the dense ones (five 864-patch solves, 106 s under ASan)
# leave the sanitized run to the library's hierarchical tests, which cover the same code.
# The second and third lines: the fifteen cases that took 31–245 s each under ASan (1,013 of the
# suite's 1,590 CPU-s): each computes a larger instance of code that smaller sanitized cases run
# (a 224-face sphere, a 16 × 16 face, row blocks of a room, 10⁵ contour pairs, the operator on
# 864+ patches and its solves, shafts of a room, a 256-gon, a scene twice at once, a sparse
# city, the analytic sparse rows of user files), so that CI stays under 40 min on two cores; and
# a run under an address-space limit (prlimit --as), which ASan's shadow memory cannot start in.
SANITIZE_SKIP_TESTS ?= differential: analytic against mc-target|sparse: analytic sparse rows of files as users write them|cli sparse: analytic sparse rows that will not fit|large polygons: (a 1000-gon|Monte-Carlo methods on 1000-gon)|obstructed: room scene|golden: |cli solve --storage hierarchical: the thermal|cli solve --storage auto|$\
obstructed roots: (a faceted sphere|a face split 16)|pipeline: any split of the rows|analytic: polygon_to_polygon agrees with integrating|hierarchical: (the error falls|a closed room.s products|products are bit-identical)|shaft culler: convex rooms|cli compute --storage hierarchical --per-surface|sparse: analytic row blocks equal|large polygons: analytic F between 256-gon|threads: the same scene computed twice|cli sparse: auto picks sparse|$\
pipeline: analytic row blocks of a room with obstruction|hierarchical: thermal and radiosity solves agree

sanitize-configure: deps
	@if [ ! -f $(SANITIZE_DIR)/CMakeCache.txt ]; then \
		cmake -S . -B $(SANITIZE_DIR) $(SANITIZE_FLAGS) $(LAUNCHER) $(CMAKE_FLAGS); \
	fi

test-sanitize: sanitize-configure
	cmake --build $(SANITIZE_DIR) -j$(JOBS)
	ASAN_OPTIONS=detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1 \
	LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp \
	UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
		ctest --test-dir $(SANITIZE_DIR) --output-on-failure -j$(JOBS) -LE '$(SANITIZE_SKIP_LABELS)' \
			-E '$(SANITIZE_SKIP_TESTS)'

# ThreadSanitizer on the tests that run computations concurrently (tests labelled `threads`).
test-tsan: deps
	@if [ ! -f $(TSAN_DIR)/CMakeCache.txt ]; then \
		cmake -S . -B $(TSAN_DIR) -DCMAKE_BUILD_TYPE=Sanitize \
			-DCMAKE_CXX_FLAGS_SANITIZE="-O1 -gline-tables-only" -DCMAKE_C_FLAGS_SANITIZE="-O1" \
			-DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang $(LAUNCHER) \
			-DFF_SANITIZE=thread -DFF_BUILD_BENCH=OFF $(CMAKE_FLAGS); \
	fi
	cmake --build $(TSAN_DIR) -j$(JOBS) --target formfactor_tests
	TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$(CURDIR)/tests/tsan.supp" \
		$(TSAN_DIR)/formfactor_tests -ts=threads

fuzz-build: sanitize-configure
	cmake --build $(SANITIZE_DIR) -j$(JOBS) --target fuzz_all

# Every reader's fuzzer for FUZZ_SECONDS (default 60), JOBS at a time (FUZZ_TARGETS: a subset).
fuzz: fuzz-build
	FUZZ_JOBS=$(JOBS) fuzz/run.sh $(SANITIZE_DIR) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

format:
	git ls-files '*.h' '*.cpp' | xargs clang-format -i

format-check: deps
	git ls-files '*.h' '*.cpp' | xargs clang-format --dry-run -Werror

clean:
	rm -rf $(BUILD_DIR) $(SANITIZE_DIR) $(TSAN_DIR)
