# Set-up and entry points. `make demo` and `make test` are the two commands in the README:
# both install missing Debian packages (as root, non-interactively), build, and leave build/esr.
.PHONY: all deps test-tools build check demo test test-release test-asan bench colmap-roundtrip lightmix-blender-check gltf-blender-check fuzz clean

DEB_PACKAGES := build-essential cmake pkg-config libspng-dev libopenexr-dev libcjson-dev \
                libjpeg62-turbo-dev libexif-dev libcmocka-dev zlib1g-dev libzip-dev imagemagick libdnnl-dev libopenblas-pthread-dev
# the Khronos glTF validator the tests check `esr export --gltf` with (npm; Node from Debian)
GLTF_VALIDATOR := gltf-validator@2.0.0-dev.3.10
JOBS  ?= $(shell nproc)
DEMO_OUT ?= runs/demo
FUZZ_TIME ?= 60

all: build

deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends $$missing; \
	fi

# Node and the glTF validator for the tests; without network the validator is skipped (said so).
test-tools: deps
	@command -v node >/dev/null && command -v npm >/dev/null || { \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends nodejs npm; }
	@[ -d build-tools/node_modules/gltf-validator ] || \
	  npm install --silent --no-audit --no-fund --prefix build-tools $(GLTF_VALIDATOR) || \
	  echo "note: $(GLTF_VALIDATOR) could not be installed; the glTF validation test will say it skipped"

CONFIGURE := cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null

build: deps
	$(CONFIGURE)
	cmake --build build -j $(JOBS)

# the quick loop: after `make build`, the unit tests of every module (ctest label `unit`: no
# training, no kills; the end-to-end runs are `e2e`, the gradient sweep `slow`), under 2 minutes
check: build
	cd build && ctest --output-on-failure -j $(JOBS) -L unit

# the demo needs only the binary: the tests' programs are built by `make check` / `make test`
demo: deps
	$(CONFIGURE)
	cmake --build build -j $(JOBS) --target esr
	./build/esr demo --out $(DEMO_OUT)

test-release: build test-tools
	cd build && ctest --output-on-failure -j $(JOBS)

test-asan: deps test-tools
	cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DESR_SANITIZE=ON >/dev/null
	cmake --build build-asan -j $(JOBS)
	cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --output-on-failure -j $(JOBS)

test: test-release test-asan

bench: build
	./build/esr bench --out bench.json

# COLMAP itself poses esr synth's renders, esr imports and trains them: camera errors and test PSNR
# against the true cameras (tests/colmap_roundtrip.sh; installs colmap and jq when missing; the
# README gives its figures and times). Not part of `make test`. Variables: WORK, RES, SPP, VIEWS,
# SIZE, TEST_VIEWS, THREADS, FEATURES.
colmap-roundtrip: build
	ESR=./build/esr tests/colmap_roundtrip.sh

# Blender's compositor opens a view of `esr lightmix`'s EXR and finds its light groups by name;
# their sum there equals OpenImageIO's (tools/lightmix_blender_check.sh; installs blender and
# openimageio-tools when missing). LIGHTMIX: an esr lightmix folder (default: the demo's).
LIGHTMIX ?= runs/demo/run/lightmix
lightmix-blender-check: build
	ESR=./build/esr tools/lightmix_blender_check.sh $(LIGHTMIX)

# Blender Cycles renders `esr export --gltf`'s asset from every lights-on test camera under esr's
# own environment map; PSNR against the photos beside esr's own direct and radiance-field renders
# (tools/gltf_blender_check.sh; installs blender when missing). RUN: a trained run (default: the
# demo's); SAMPLES: Cycles samples per pixel.
RUN ?= runs/demo/run
SAMPLES ?= 256
gltf-blender-check: build
	ESR=./build/esr tools/gltf_blender_check.sh $(RUN) "" $(SAMPLES)

# libFuzzer harnesses (fuzz/), clang with ASan+UBSan, each run FUZZ_TIME seconds in turn on one
# core; exit status 1 on any crash, leak, sanitizer report or memory blow-up (fuzz/run.sh).
fuzz: deps
	@command -v clang >/dev/null || { SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends clang libomp-dev; }
	CC=clang cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DESR_FUZZ=ON -DESR_TESTS=OFF >/dev/null
	cmake --build build-fuzz -j $(JOBS)
	fuzz/run.sh build-fuzz $(FUZZ_TIME)

clean:
	rm -rf build build-asan build-tools build-fuzz
