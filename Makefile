# Wraps CMake so that two commands do everything on a fresh Debian 12 machine:
#   make run   installs missing packages, builds the tritrace command (Release), renders
#              out/cornell.png
#   make test  the same set-up and flags in the same build folder, so it reuses what `make run`
#              compiled and builds the rest (tests, viewer, Python module, benchmarks), then runs
#              the whole test suite through ctest
# CMake stays the real build; BUILD_DIR, CMAKE_FLAGS and WERROR can be overridden.
#   make test-asan  the test suite built with AddressSanitizer + UndefinedBehaviorSanitizer
#   make test-tsan  the multi-threaded tests built with ThreadSanitizer
#   make test-portable  the BVH, renderer and kernel tests built for any AVX2 CPU (x86-64-v3)
#   make leaks      the full closed-mesh leak count for every kernel (docs/RELIABILITY.md)
#   make lint       clang-tidy over src/ and apps/ (.clang-tidy)
#   make install    the Python module (import tritrace) and its stub into Python's packages folder
#                   under PREFIX (default /usr/local: /usr/local/lib/python3.X/dist-packages)
BUILD_DIR ?= build
CMAKE_FLAGS ?=
JOBS ?= $(shell nproc)
ASAN_DIR ?= build-asan
TSAN_DIR ?= build-tsan
PORTABLE_DIR ?= build-portable
PREFIX ?= /usr/local
# -Werror (TRITRACE_WERROR) in BUILD_DIR: `make run`, `make build` and `make test` configure it
# with the same flags, so none of them recompiles what another compiled. WERROR empty (the
# default) passes nothing and build/'s cache decides: off in a fresh folder, so that a newer
# compiler's new warning does not stop a user's build. `make WERROR=ON test` turns it on, as CI
# does in its own folder (.ci/run); the sanitizer and portable builds, in their own folders, always
# have it.
WERROR ?=
WERROR_FLAG = $(if $(WERROR),-DTRITRACE_WERROR=$(WERROR))
CONFIGURE = cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(WERROR_FLAG) $(CMAKE_FLAGS) \
  >/dev/null
# Sanitized builds: optimised (the tests trace millions of rays) with debug info for reports; no
# benchmarks.
# MPI is left out: Open MPI dlcloses its components in MPI_Finalize, so LeakSanitizer reports their
# process-lifetime allocations (about 120 KB in 3300 blocks per rank) with stacks that end in an
# unknown module, which no suppression can name. The MPI test passed under ASan + UBSan with leak
# detection off (docs/DISTRIBUTED.md); the normal build runs it in `make test`.
# Line tables only (-g1): reports still name function, file and line, while one test file compiles
# in 0.8x the time (path_integrator_test.cpp under ASan: 13.8 s against 17.2 s of CPU) and its
# object is half the size, which shortens the links too.
# The library as a unity build (TRITRACE_UNITY: eight of its files per compiler run): these builds
# start from nothing every time (at -O3, 77 s of CPU for the library against 125 s).
# The test files at -O1 (TRITRACE_TEST_OPTIMIZE), the library at -O2: the tests' hot loops are the
# library's, and a test file compiles in two thirds of the time (render/bdpt_test.cpp under
# ASan + UBSan: 19.1 s against 29.7 s of CPU).
SANITIZE_FLAGS = -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTRITRACE_BUILD_BENCH=OFF -DTRITRACE_WITH_MPI=OFF \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" \
  -DTRITRACE_WERROR=ON -DTRITRACE_UNITY=ON -DTRITRACE_TEST_OPTIMIZE=-O1
# The sanitizer builds are clang 14's (scripts/install-deps.sh installs it and its sanitizer
# runtimes): it compiles the instrumented files in about 0.6x g++ 12's time (render/bsdf_test.cpp
# 5.7 against 9.2 s, render/delta_lights_test.cpp 7.5 against 11.8 s under ASan + UBSan; the whole
# ASan build about 7.5 minutes on 2 cores against about 15; CI's ASan stage 794 s against 1281),
# and its -Werror and sanitizer checks are a second compiler's. The README's build stays g++'s, as
# does the portable one. The compiler is named on the command line, so a folder configured with
# another one is configured afresh. The TSan stage (build and tests) took about 130 s with clang
# (build 85, tests 45) against 250-284 s with g++ in CI; clang's reports name an atomic's
# innermost frame without its class, so .ci/tsan.supp also matches libstdc++'s atomic_base.h by
# file.
SANITIZE_COMPILERS = -DCMAKE_CXX_COMPILER=clang++-14
# UBSan's `undefined` group leaves out float-cast-overflow (a float-to-int cast of a value out of
# the int's range, inf or NaN: undefined behaviour), so it is named as well.
# Left out under ASan: this test feeds libassimp a file that crashes it, on purpose, in the isolated
# importer's child process; ASan then prints its report of that (third-party) crash on the stderr
# the test checks holds exactly one line. The parent's behaviour is still right (exit 1, one
# 'cannot import' line); the test runs in the normal build.
# Also left out there, to keep CI's sanitizer stage short: the BVH-against-brute-force tests of the
# Morton-built trees with the inverse, Cramer and Moller-Trumbore kernels (the Morton builder runs
# under ASan in the watertight kernel's instances, each kernel in the SAH-built tree's), twelve of
# bdpt's long statistical agreements whose code paths other tests run under ASan (the other bdpt
# tests, instanced renders, glTF normal maps, the path tracer's textures; for spot and directional
# lights, lenses and orthographic cameras the weight tests and light tracing onto a plane), bdpt's
# two statistical tests of adaptive sampling (its bit comparisons and weight walk stay), the
# coherent-packet comparisons of the inverse and Moller-Trumbore kernels (Cramer's and the
# watertight one's stay), the brute-force accel's allocation count (the BVH's stays) and the slow
# render without a terminal (since the eleventh session its twin on a terminal too, 14.5 s under
# ASan; the CLI's progress line runs in the normal build; and the Slurm job array, 15.8 s, whose
# --spp-range merges the distributed CLI tests run under ASan; and bdpt's view rays on
# caustics.json, the pilot's sixteen seeds on it and two agreements at a light-path share, 5-6 s
# each, whose code the slab tests, the pilot's other tests and the share's weight, bit and
# sum tests run under ASan; the CI at 4a17d97 took 31m14s, ASan 821 s). Since 2edd112 (the clean-clone CI took
# 31m38s, its ASan stage 437 s) also: five more of bdpt's statistical tests (an emitter inside
# glass, light subpaths through glass, the lab's point-light box, unweighted strategies of one
# length, max depth; bdpt's agreements under environments and on rough and principled glass, its
# weight walk, light tracing and furnace tests stay), the adaptive weight walk with count ratios
# (adaptive bdpt's bit comparisons stay), the path tracer's pilot-budget test (its unbiasedness
# test stays), the Cramer kernel against brute force in the SAH tree (the kernel agreement tests
# run it) and the 4096-pixel lab image (the smaller sizes stay). All of them run in `make test`.
# The library's tests (tritrace_tests, ctest label `library`) run as $(JOBS) GoogleTest shards,
# one process each (scripts/gtest_shards.sh): under ASan a process takes 0.3-0.4 s to start,
# which ctest's one process per test paid about a thousand times (the clean-clone CI's ASan stage
# took 1420 s at 1ba443d). ASAN_SKIP: their tests left out, as GoogleTest patterns (the leading *
# takes a parameterised test's instantiation prefix; GoogleTest names a value-parameterised test
# by its index, so the 4096-pixel lab image is NoRaySlipsThroughTheRoom/6). The CLI, viewer,
# allocation, fuzz-regression and distributed tests run through ctest; ASAN_EXCLUDE: theirs left
# out, one group of alternatives and one end anchor (a parameterised test's name is followed by
# '  # GetParam()'): CMake's regular expressions allow at most ten groups and match nothing past
# that, which would silently exclude nothing.
empty :=
space := $(empty) $(empty)
ASAN_SKIP = *Bdpt.AgreesWithThePathTracerOnAnEmitterInsideGlass \
  *Bdpt.LightSubpathThroughGlassAgreesWithTheCameraSubpath \
  *Bdpt.AgreesWithThePathTracerOnTheLabPointLightBox *Bdpt.UnweightedStrategiesOfOneLengthAgree \
  *Bdpt.MaxDepthCountsBouncesAsThePathTracerDoes \
  *BdptAdaptive.WeightRecursionEqualsTheRatioWalkWithCountRatios \
  *AdaptiveSampling.PixelsAmongFlatNeighboursStopAfterThePilotAmongNoisyOnesGoOn \
  *BvhVsBrute.*/cramer *DefaultLabImage.NoRaySlipsThroughTheRoom/6 \
  *BvhVsBrute.*/inverse_morton *BvhVsBrute.*/cramer_morton *BvhVsBrute.*/mollertrumbore_morton \
  *BvhVsBrute.CoherentPacketsSameHitsBitForBit/inverse \
  *BvhVsBrute.CoherentPacketsSameHitsBitForBit/mollertrumbore \
  *Bdpt.AgreesWithThePathTracerOnGlassAndRoughMetal *Bdpt.AgreesWithThePathTracerOnCornellArea \
  *Bdpt.AgreesWithThePathTracerOnInstances \
  *Bdpt.AgreesWithThePathTracerWithNormalMapsAndVertexColours \
  *Bdpt.AgreesWithThePathTracerWithShadingNormalsAndTextures \
  *Bdpt.AgreesWithThePathTracerUnderASpotLight *Bdpt.AgreesWithThePathTracerUnderADirectionalLight \
  *Bdpt.AgreesWithThePathTracerUnderSpotAndDirectionalLightsTogether \
  *Bdpt.AgreesWithThePathTracerThroughA* *Bdpt.UnweightedEnvironmentStrategiesAgree \
  *BdptAdaptive.ImageMeanOverSeedsAgreesWithUniformBdptAndThePathTracer \
  *BdptAdaptive.WeightsStayAPartitionOfUnityForCountRatiosOtherThanOne \
  *BdptCaustics.AgreesWithThePathTracerAndWithoutTheGuide \
  *BdptViews.CausticsSceneAgreesWithThePathTracerAndWithoutViewRays \
  *BdptPilot.ChoosesAShareBelowAHalfForCausticsThroughGlass \
  *Bdpt.AgreesWithThePathTracerWithALightPathShare *Bdpt.UnweightedStrategiesWithALightPathShareAgree
ASAN_EXCLUDE = (CliTest\.ModelThatCrashesTheImporterIsAnError|CliTest\.SlowRenderWithoutATerminalPrintsNoProgress|CliTest\.SlowRenderOnATerminalShowsProgress|Distributed\.SlurmJobArrayMatchesOneProcess|HotPath\.TileLoopAllocatesNothing/brute)( |$$)
ASAN_ENV = ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
  LSAN_OPTIONS=suppressions=$(CURDIR)/.ci/lsan.supp:print_suppressions=0 \
  UBSAN_OPTIONS=print_stacktrace=1
# The viewer's tests run under ASan too; .ci/lsan.supp names the two libraries (Xlib, libdbus) whose
# deliberate process-lifetime allocations LeakSanitizer would otherwise report when it exits.
# The multi-threaded tests: the renderer's (thread-count and tile-size invariance through brute
# force, the BVH's packet path and Embree's three modes; the threads it runs; whole images), the
# parallel SAH and Morton builds (serial against parallel) and the Embree
# backend, whose build runs on TBB threads; the wide BVH's build (BvhInvariants.*) and the path
# tracer's multi-threaded renders (PathRender.*); bdpt's `--light-paths auto` pilot, whose batches
# run on the arena's threads (BdptPilot.IsDeterministicOnAnyThreadCount); and the task group's own
# hand-overs (ParallelTsan.*, tests/parallel/parallel_tsan_test.cpp).
TSAN_TESTS = ParallelTsan.*:Renderer.*:Placements/*:BinnedSahBuilder.ParallelBuildMakesTheSerialTree:MortonBuilder.ParallelBuildMakesTheSerialTree:Modes/EmbreeVsBrute.*:EmbreeAccel.*:BvhInvariants.*:PathRender.*:BdptPilot.IsDeterministicOnAnyThreadCount
# They live in the test files that tests/CMakeLists.txt builds alone as tritrace_tsan_tests.

# The portable build (TRITRACE_NATIVE=OFF: -march=x86-64-v3, AVX2) compiles the AVX2 code paths,
# which a -march=native build on an AVX-512 machine does not; only the tests of the code that
# differs between the two are built and run (tritrace_portable_tests, tests/CMakeLists.txt): BVH
# build and traversals, kernels, leak counts, ray offsets, the Sobol sampler, the camera, the lab
# integrator, the path tracer and the renderer.
# The test files at -O1 here too (TRITRACE_TEST_OPTIMIZE), the library at the Release build's -O3.
PORTABLE_FLAGS = -DCMAKE_BUILD_TYPE=Release -DTRITRACE_NATIVE=OFF -DTRITRACE_BUILD_BENCH=OFF \
  -DTRITRACE_VIEWER=OFF -DTRITRACE_WERROR=ON -DTRITRACE_UNITY=ON -DTRITRACE_TEST_OPTIMIZE=-O1

.PHONY: all deps configure build run test test-asan test-tsan test-portable leaks bench format \
  lint install clean

all: build

deps:
	@./scripts/install-deps.sh

configure: deps
	@$(CONFIGURE)

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

# Only the command it runs (tritrace_cli is the target of the tritrace binary).
run: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS) --target tritrace_cli
	@mkdir -p out
	@$(BUILD_DIR)/tritrace render -o out/cornell.png

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

test-asan: deps
	@cmake -S . -B $(ASAN_DIR) $(SANITIZE_FLAGS) $(SANITIZE_COMPILERS) \
	  -DTRITRACE_SANITIZE=address,undefined,float-cast-overflow >/dev/null
	@cmake --build $(ASAN_DIR) -j $(JOBS)
	@cd $(ASAN_DIR)/tests && $(ASAN_ENV) $(CURDIR)/scripts/gtest_shards.sh ./tritrace_tests $(JOBS) \
	  '-$(subst $(space),:,$(strip $(ASAN_SKIP)))'
	@cd $(ASAN_DIR) && $(ASAN_ENV) ctest --output-on-failure -j $(JOBS) -LE library \
	  -E '$(ASAN_EXCLUDE)'

test-tsan: deps
	@cmake -S . -B $(TSAN_DIR) $(SANITIZE_FLAGS) $(SANITIZE_COMPILERS) -DTRITRACE_SANITIZE=thread \
	  >/dev/null
	@cmake --build $(TSAN_DIR) -j $(JOBS) --target tritrace_tsan_tests
	@TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$(CURDIR)/.ci/tsan.supp" \
	  $(TSAN_DIR)/tests/tritrace_tsan_tests --gtest_filter='$(TSAN_TESTS)'

# Where the native build has no AVX-512 (the compiler's -march=native does not define
# __AVX512F__), it already compiles and tests the AVX2 paths, the only ones the sources choose by
# (__AVX2__ and __AVX512F__ are all they test), so the portable build would repeat it: skipped, and
# said so. CI machines with AVX-512 run it.
test-portable: deps
	@if ! echo | $${CXX:-c++} -march=native -dM -E - | grep -q __AVX512F__; then \
	  echo "test-portable: skipped: this machine has no AVX-512, so 'make test' already ran the AVX2 code paths"; \
	else \
	  cmake -S . -B $(PORTABLE_DIR) $(PORTABLE_FLAGS) >/dev/null && \
	  cmake --build $(PORTABLE_DIR) -j $(JOBS) --target tritrace_portable_tests && \
	  $(PORTABLE_DIR)/tests/tritrace_portable_tests; \
	fi

install: build
	@cmake --install $(BUILD_DIR) --prefix $(PREFIX)

leaks: build
	@$(BUILD_DIR)/tritrace_leaks

bench: build
	@$(BUILD_DIR)/bench/tritrace_bench

format:
	@git ls-files '*.h' '*.cpp' | xargs clang-format -i

lint: configure
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >/dev/null
	@git ls-files 'src/*.cpp' 'apps/*.cpp' | xargs clang-tidy -p $(BUILD_DIR) --quiet

clean:
	@rm -rf $(BUILD_DIR) build-ci $(ASAN_DIR) $(TSAN_DIR) $(PORTABLE_DIR) out
