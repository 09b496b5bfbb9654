# Wraps CMake so that two commands do everything on a fresh Debian 12 machine:
#   make run   installs missing packages, builds Release, renders out/cornell.png
#   make test  the same set-up, then the whole test suite through ctest
# CMake stays the real build; BUILD_DIR and CMAKE_FLAGS can be overridden.
BUILD_DIR ?= build
CMAKE_FLAGS ?=
JOBS ?= $(shell nproc)

.PHONY: all deps configure build run test bench format lint clean

all: build

deps:
	@./scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

run: build
	@mkdir -p out
	@$(BUILD_DIR)/tritrace render -o out/cornell.png

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

bench: build
	@$(BUILD_DIR)/bench/tritrace_bench

format:
	@git ls-files '*.h' '*.cpp' | xargs clang-format -i

lint: configure
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >/dev/null
	@git ls-files 'src/*.cpp' 'apps/*.cpp' | xargs clang-tidy -p $(BUILD_DIR) --quiet

clean:
	@rm -rf $(BUILD_DIR) out
