# ffseg front door. CMake is the build; these targets wrap it.
#   make deps    install what is missing (apt-get; the viewer's npm packages by npm ci
#                from web/package-lock.json; safe to run twice)
#   make         build/libffseg.a, build/libffseg.so, tools, tests, examples
#   make test    deps + build + every test (ctest)
#   make demo    deps + build + the main job
#   make bench   deps + build + benchmarks (tables on stdout)
#   make check-python  the Python module's tests alone (pytest under /usr/bin/python3)
#   make install PREFIX=/usr/local   (library, header, ffseg tool, Python package)
#   make check-abi     rebuild libffseg.so with debug info (build-abi/), abidiff it against abi/
#   make abi-baseline  rewrite abi/libffseg.so.0.abi (only after a version bump if the ABI changed)
#   make check-bindings  install into build-bindings/prefix; build and run the C (pkg-config),
#                        C/C++ (find_package), Rust and C# consumers and their tests against it
#   make wasm          the library compiled to WebAssembly (emscripten): build-wasm/ffseg.js + .wasm
#   make check-wasm    the JavaScript binding's Node tests (bindings/js/test) against the wasm build
#   make web           build the viewer page (web/dist) and serve web/ on http://127.0.0.1:$(WEB_PORT)/
#   make check-browser the viewer in headless Chromium against the ffseg tool (web/test)
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
PREFIX ?= /usr/local
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

DEB_PACKAGES := cmake make g++ pkg-config libeigen3-dev doctest-dev zlib1g-dev libstb-dev \
                clang libclang-rt-14-dev liblapack-dev libopenblas-dev mricron-data
# Python module, batch and image formats (issue 18): the tests run under /usr/bin/python3.
DEB_PACKAGES += python3-numpy python3-pytest python3-distributed python3-nibabel python3-pydicom \
                libgdcm-dev
# DICOM Segmentation and RT Structure Set out through DCMTK, checked with dciodvfy (issue 31).
DEB_PACKAGES += libdcmtk-dev dicom3tools
# Rust and C# bindings, ABI check (issue 17): Debian's rustc 1.63 / cargo, Mono, libabigail.
DEB_PACKAGES += rustc cargo mono-mcs mono-runtime abigail-tools
# The browser build and its checks (issue 32): emscripten 3.1.6 (it brings Debian's
# Node.js), Chromium for the headless page test. npm is installed below only when
# no npm is on the PATH: a Node.js from elsewhere bundles its own and conflicts
# with Debian's npm package.
DEB_PACKAGES += emscripten chromium

.PHONY: all build deps test demo bench install clean fuzz fuzz-smoke fuzz-soak coverage check-sanitizers check-portable check-python \
        check-bindings check-abi abi-baseline wasm check-wasm web web-dist check-browser

all: build

deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	command -v npm >/dev/null 2>&1 || missing="$$missing npm"; \
	if [ -n "$$missing" ]; then \
	  echo "deps: installing$$missing"; \
	  SUDO=""; [ "$$(id -u)" -eq 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends $$missing; \
	else echo "deps: all present"; fi
	@$(MAKE) --no-print-directory web/node_modules/.package-lock.json

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) $(CMAKE_FLAGS)

build: $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

test: deps
	$(MAKE) build
	cd $(BUILD) && ctest --output-on-failure --timeout 900

# The main job: segment the left putamen in the Colin27 T1 MRI and compare it
# with its AAL label (73). The sphere follows the evaluation protocol: centre =
# the label voxel farthest from the label's border (-20, 14, -4 mm), radius =
# half that distance (2.92 mm); --sphere-from-label computes both.
# Then chapter 4 on a real complex shape: the brain mask (ch2bet), binary.
# Then chapter 6: the eight deep nuclei at once in one engine (AAL 71-78), each
# from its protocol sphere, grey levels, with their bounding regions; labels.nii.gz
# holds all eight under their AAL numbers (about 7 s on one core).
MRI := /usr/share/mricron/templates
NUCLEI_LABELS := 71 72 73 74 75 76 77 78
NUCLEI_NAMES := caudate_L,caudate_R,putamen_L,putamen_R,pallidum_L,pallidum_R,thalamus_L,thalamus_R
DEMO_OUT ?= out
# The shared abdominal CT (beside the repository, not in it): liver, spleen,
# kidneys right and left, vena cava (TotalSegmentator v1 ids).
ABDOMEN := ../shared/data/abdomen_ct
ABDOMEN_LABELS := 5 1 2 3 8
ABDOMEN_NAMES := liver,spleen,kidney_R,kidney_L,vena_cava
demo: deps
	$(MAKE) build
	mkdir -p $(DEMO_OUT)
	./$(BUILD)/ffseg segment $(MRI)/ch2.nii.gz --sphere-from-label $(MRI)/aal.nii.gz:73 \
	  --truth $(MRI)/aal.nii.gz --truth-labels 73 --names putamen_L --out $(DEMO_OUT)/putamen_L --force --consensus
	./$(BUILD)/ffseg segment $(MRI)/ch2bet.nii.gz --target binary --sphere 0,-17,19,80 \
	  --names brain --out $(DEMO_OUT)/brain --force
	@echo; echo "demo: the eight deep nuclei (AAL $(NUCLEI_LABELS)) together in one engine"
	@./$(BUILD)/ffseg segment $(MRI)/ch2.nii.gz $(foreach l,$(NUCLEI_LABELS),--sphere-from-label $(MRI)/aal.nii.gz:$(l)) \
	  --truth $(MRI)/aal.nii.gz --names $(NUCLEI_NAMES) \
	  --regions $(DEMO_OUT)/nuclei_regions.nii.gz --out $(DEMO_OUT)/nuclei --force --quiet
	@echo; if [ -f $(ABDOMEN)/ct.nii.gz ]; then \
	  echo "demo: five organs of the abdominal CT ($(ABDOMEN), 3 mm) together in one engine (a stalled organ"; \
	  echo "      is warned about and written, exit 6: the demo goes on)"; \
	  ./$(BUILD)/ffseg segment $(ABDOMEN)/ct.nii.gz $(foreach l,$(ABDOMEN_LABELS),--sphere-from-label $(ABDOMEN)/labels.nii.gz:$(l)) \
	    --truth $(ABDOMEN)/labels.nii.gz --names $(ABDOMEN_NAMES) --out $(DEMO_OUT)/abdomen --force --quiet \
	    || [ $$? -eq 6 ]; \
	  else echo "demo: $(ABDOMEN) is absent (the shared data beside the repository): the abdominal run is skipped"; fi
	@echo; echo "demo: outputs (meshes, labels.nii.gz, overlay.png, report.json) in $(DEMO_OUT)/putamen_L, $(DEMO_OUT)/brain, $(DEMO_OUT)/nuclei (bounding regions: $(DEMO_OUT)/nuclei_regions.nii.gz) and $(DEMO_OUT)/abdomen"

# The Python tests (also part of `make test` as ctest's `python` test).
check-python: deps
	cmake -S . -B $(BUILD) $(CMAKE_FLAGS)
	cmake --build $(BUILD) -j $(JOBS) --target ffseg_shared ffseg_cli ffseg_abi_layout
	cd $(BUILD) && ctest --output-on-failure -R '^python$$'

bench: deps
	$(MAKE) build
	@for b in $(BUILD)/bench_*; do [ -x "$$b" ] && { echo "== $$b"; "$$b"; }; done

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

# Only what is installed is built for it (the libraries and the ffseg tool).
BINDINGS_WORK ?= build-bindings
check-bindings: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS) --target ffseg_static ffseg_shared ffseg_cli
	bindings/check.sh $(BUILD) $(BINDINGS_WORK)

# The ABI: only the shared library is built, with debug information for abidw.
ABI_BUILD ?= build-abi
$(ABI_BUILD)/libffseg.so.0: FORCE
	cmake -S . -B $(ABI_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo
	cmake --build $(ABI_BUILD) -j $(JOBS) --target ffseg_shared
check-abi: deps $(ABI_BUILD)/libffseg.so.0
	abi/check.sh $(ABI_BUILD)
abi-baseline: deps $(ABI_BUILD)/libffseg.so.0
	abi/check.sh --update $(ABI_BUILD)
FORCE:

clean:
	rm -rf $(BUILD)

# ---- the browser (issue 32) ----------------------------------------------------
# Debian's emcc runs its JavaScript tools with Debian's Node modules.
WASM_BUILD ?= build-wasm
WEB_PORT ?= 8032
EMSCRIPTEN_ENV := NODE_PATH=/usr/share/nodejs

$(WASM_BUILD)/CMakeCache.txt:
	$(EMSCRIPTEN_ENV) emcmake cmake -S wasm -B $(WASM_BUILD) -DCMAKE_BUILD_TYPE=Release

wasm: deps $(WASM_BUILD)/CMakeCache.txt
	$(EMSCRIPTEN_ENV) nice -n 10 cmake --build $(WASM_BUILD) -j $(JOBS)

# The Colin27 comparison runs the native tool: it is built too.
check-wasm: wasm $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS) --target ffseg_cli
	FFSEG_WASM_DIR=$(CURDIR)/$(WASM_BUILD) FFSEG_CLI=$(CURDIR)/$(BUILD)/ffseg node --test bindings/js/test/*.test.js

# npm packages only from web/package-lock.json.
web/node_modules/.package-lock.json: web/package.json web/package-lock.json
	cd web && npm ci --no-audit --no-fund
	touch $@

web-dist: wasm web/node_modules/.package-lock.json
	node web/build.js $(WASM_BUILD)

web: web-dist
	node web/serve.js $(WEB_PORT)

# FFSEG_SCREENSHOT=docs/viewer.png also keeps the screenshot taken after segmenting.
check-browser: web-dist $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS) --target ffseg_cli
	FFSEG_CLI=$(CURDIR)/$(BUILD)/ffseg node --test web/test/browser.test.js

# ---- robustness: libFuzzer targets and sanitizer builds (FUZZING.md) -----------
#   make fuzz              build the three fuzzers into build-fuzz/ (clang)
#   make fuzz-smoke        run each for FUZZ_SECONDS on a copy of its corpus; any
#                          finding (crash, sanitizer report, leak, timeout) fails;
#                          prints each target's executions per second
#   make fuzz-soak         the same on persistent corpora, totals appended to FUZZING.md
#   make coverage          llvm-cov line coverage (unit tests + corpus replay) per folder
#   make check-sanitizers  ctest under ASan+UBSan (build-asan/), and the thread
#                          tests under TSan (build-tsan/)
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?= volume nifti calls nrrd metaimage
# gcc for the sanitizer builds: clang's ASan leaves its runtime out of shared
# libraries, which libffseg.so (linked with --no-undefined) cannot accept.
SAN_CC ?= gcc
SAN_CXX ?= g++

fuzz: deps
	CC=clang CXX=clang++ cmake -S fuzz -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo
	cmake --build $(FUZZ_BUILD) -j $(JOBS)

fuzz-smoke: fuzz
	FUZZ_BUILD=$(FUZZ_BUILD) fuzz/run.sh smoke $(FUZZ_SECONDS) "$(FUZZ_TARGETS)"

# Every target FUZZ_SECONDS on its persistent corpus ($(FUZZ_BUILD)/soak/), one
# after the other; appends the totals to FUZZING.md's soak log.
fuzz-soak: fuzz
	FUZZ_BUILD=$(FUZZ_BUILD) fuzz/run.sh soak $(FUZZ_SECONDS) "$(FUZZ_TARGETS)"

# clang source-based coverage over the unit tests and a replay of the fuzz
# corpora: line coverage per folder of src/, capi/ and tools/, and a total.
coverage: deps
	JOBS=$(JOBS) scripts/coverage.sh

# The portable code paths alone (what a non-x86 CPU builds): every test must
# pass with the same results as the x86 kernels.
check-portable: deps
	cmake -S . -B build-portable -DCMAKE_BUILD_TYPE=Release -DFFSEG_PORTABLE=ON
	cmake --build build-portable -j $(JOBS)
	cd build-portable && ctest --output-on-failure --timeout 3600

check-sanitizers: deps
	CC=$(SAN_CC) CXX=$(SAN_CXX) cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFFSEG_SANITIZE=ON
	cmake --build build-asan -j $(JOBS)
	cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure --timeout 3600
	CC=$(SAN_CC) CXX=$(SAN_CXX) cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFFSEG_TSAN=ON
	cmake --build build-tsan -j $(JOBS) --target ffseg_tests
	TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 ./build-tsan/ffseg_tests --test-case='threads:*'
