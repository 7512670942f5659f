# formfactor: the README's two set-up commands, `make run` and `make test`, on a fresh Debian 12.
# Each installs the Debian packages that are missing (apt-get, only when something is missing),
# configures and builds Release into build/, then runs the main job or every test.

BUILD_DIR ?= build
JOBS ?= 2
CMAKE_FLAGS ?=

DEB_PACKAGES := cmake g++ make pkg-config \
	libembree-dev libtbb-dev libeigen3-dev libcli11-dev nlohmann-json3-dev libfmt-dev \
	libtinyobjloader-dev libstb-dev doctest-dev libbenchmark-dev pybind11-dev \
	python3-dev python3-numpy python3-pytest

SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps configure build run test bench format clean

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

format:
	git ls-files '*.h' '*.cpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR)
