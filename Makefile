# Thin front for CMake. `make demo` and `make test` set everything up from a fresh machine.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: deps configure build demo test bench plots format clean

deps:
	bash scripts/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD) -G Ninja $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	mkdir -p out
	$(BUILD)/bin/penumbra render cornell --spp 256 -o out/cornell.png -o out/cornell.exr --stats out/cornell-stats.json

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

bench: build
	mkdir -p bench-out
	$(BUILD)/bin/ray_bench --benchmark_out=bench-out/ray_bench.json --benchmark_out_format=json
	$(BUILD)/bin/hybrid_bench --benchmark_out=bench-out/hybrid_bench.json --benchmark_out_format=json
	$(BUILD)/bin/radiosity_bench --benchmark_out=bench-out/radiosity_bench.json --benchmark_out_format=json
	$(BUILD)/bin/progressive_bench --benchmark_out=bench-out/progressive_bench.json --benchmark_out_format=json

plots:
	/usr/bin/python3 scripts/plot_matrix_bench.py bench-out/radiosity_bench.json docs/images/matrix_fig4.png

format:
	clang-format -i $$(git ls-files '*.cpp' '*.h' '*.hpp')

clean:
	rm -rf $(BUILD) out bench-out
