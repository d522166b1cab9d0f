# Thin front for CMake. `make demo` and `make test` set everything up from a fresh machine.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: all deps configure build install demo test test-asan test-asan-fast fuzz fuzz-build bench plots format clean

# `make`: everything, the Python module included (build/python/penumbra).
all: build

deps:
	bash scripts/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD) -G Ninja $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD) -j $(JOBS)

# The library as a package (docs/library.md): header, static and shared library, CMake config,
# penumbra.pc.
PREFIX ?= /usr/local
install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

# The demo needs the CLI and the library only: not the tests, benchmarks, viewer or Python module.
demo: configure
	cmake --build $(BUILD) -j $(JOBS) --target penumbra_cli
	mkdir -p out
	$(BUILD)/bin/penumbra render cornell --spp 256 -o out/cornell.png -o out/cornell.exr --stats out/cornell-stats.json

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in its own build folder.
# ASAN_TESTS narrows it to a GoogleTest filter.
ASAN_BUILD ?= build-asan
ASAN_TESTS ?= *
test-asan: deps
	cmake -S . -B $(ASAN_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPENUMBRA_SANITIZE=ON \
	  -DPENUMBRA_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1"
	cmake --build $(ASAN_BUILD) -j $(JOBS) --target penumbra_tests penumbra_cli
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  $(ASAN_BUILD)/bin/penumbra_tests --gtest_filter='$(ASAN_TESTS)'

# The sanitizer job .ci/run runs: the tests of the modules that take input and build from it
# (tests/CMakeLists.txt: penumbra_fast_tests) at -O0, which compiles in about half the time, with
# the solvers uninstrumented (src/CMakeLists.txt: PENUMBRA_SANITIZE_SOLVERS), less the few of them that take more than about 2 s without sanitizers and the command-line
# tests that run a whole solve (their solvers' own suites are not in this job either).
ASAN_FAST_BUILD ?= build-asan-fast
ASAN_SLOW_TESTS = HostileValues.Resume*:HostileValues.Sigterm*:Cli.Progressive*:Cli.Stochastic*:Cli.Lpv*:Cli.MatrixRadiosity*:Cli.Bake*:Cli.PathTracerSamplers*:Cli.Signals*:Cli.TraceOnTheGpu*:ChartAtlas.Bunny*:SurfaceHierarchy.CutGives*:Readme.*:GltfCorpus.GpuInstancesAreEveryCopy:GltfCorpus.CompressedVariantsGiveThePlainFilesPicture:BakeFiles.*:ImageDecode.*Bomb*
test-asan-fast: deps
	cmake -S . -B $(ASAN_FAST_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPENUMBRA_SANITIZE=ON \
	  -DPENUMBRA_SANITIZE_SOLVERS=OFF -DPENUMBRA_BUILD_BENCH=OFF \
	  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O0 -g1"
	cmake --build $(ASAN_FAST_BUILD) -j $(JOBS) --target penumbra_fast_tests penumbra_cli
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  $(ASAN_FAST_BUILD)/bin/penumbra_fast_tests --gtest_filter='-$(ASAN_SLOW_TESTS)'

# libFuzzer (clang from Debian): every target in fuzz/ runs FUZZ_SECONDS on its corpus in
# fuzz/corpus/<target>, which grows with what it finds; crashes land in fuzz-out/.
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?= obj ply gltf scene_json rays image checkpoint ldt ies scene_values gltf_values meshopt
fuzz-build: deps
	CXX=clang++ cmake -S . -B $(FUZZ_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DPENUMBRA_FUZZ=ON -DPENUMBRA_BUILD_TESTS=OFF -DPENUMBRA_BUILD_BENCH=OFF \
	  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1"
	cmake --build $(FUZZ_BUILD) -j $(JOBS) $(addprefix --target fuzz_,$(FUZZ_TARGETS))

fuzz: fuzz-build
	mkdir -p fuzz-out
	for t in $(FUZZ_TARGETS); do \
	  mkdir -p fuzz/corpus/$$t && \
	  $(FUZZ_BUILD)/bin/fuzz_$$t fuzz/corpus/$$t -max_total_time=$(FUZZ_SECONDS) -timeout=10 \
	    -rss_limit_mb=4096 -max_len=1048576 -artifact_prefix=fuzz-out/$$t- \
	    -print_final_stats=1 2>&1 | tail -n 20 || exit 1; \
	done

bench: build
	mkdir -p bench-out
	$(BUILD)/bin/ray_bench --benchmark_out=bench-out/ray_bench.json --benchmark_out_format=json
	$(BUILD)/bin/hybrid_bench --benchmark_out=bench-out/hybrid_bench.json --benchmark_out_format=json
	$(BUILD)/bin/radiosity_bench --benchmark_out=bench-out/radiosity_bench.json --benchmark_out_format=json
	$(BUILD)/bin/progressive_bench --benchmark_out=bench-out/progressive_bench.json --benchmark_out_format=json
	$(BUILD)/bin/stochastic_bench --benchmark_out=bench-out/stochastic_bench.json --benchmark_out_format=json
	$(BUILD)/bin/applications_bench --benchmark_out=bench-out/applications_bench.json --benchmark_out_format=json
	$(BUILD)/bin/gltf_bench --benchmark_out=bench-out/gltf_bench.json --benchmark_out_format=json

plots: build
	mkdir -p bench-out
	/usr/bin/python3 scripts/plot_matrix_bench.py bench-out/radiosity_bench.json docs/images/matrix_fig4.png
	$(BUILD)/bin/convergence_plot docs/images > bench-out/convergence.csv

format:
	clang-format -i $$(git ls-files '*.cpp' '*.h' '*.hpp')

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(ASAN_FAST_BUILD) $(FUZZ_BUILD) out bench-out fuzz-out
