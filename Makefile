# ffseg front door. CMake is the build; these targets wrap it.
#   make deps    install what is missing (apt-get; safe to run twice)
#   make         build/libffseg.a, build/libffseg.so, tools, tests, examples
#   make test    deps + build + every test (ctest)
#   make demo    deps + build + the main job
#   make bench   deps + build + benchmarks (tables on stdout)
#   make install PREFIX=/usr/local
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
PREFIX ?= /usr/local
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

DEB_PACKAGES := cmake make g++ pkg-config libeigen3-dev doctest-dev zlib1g-dev libstb-dev \
                clang libclang-rt-14-dev liblapack-dev libopenblas-dev mricron-data

.PHONY: all build deps test demo bench install clean fuzz fuzz-smoke check-sanitizers

all: build

deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "deps: installing$$missing"; \
	  SUDO=""; [ "$$(id -u)" -eq 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends $$missing; \
	else echo "deps: all present"; fi

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) $(CMAKE_FLAGS)

build: $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

test: deps
	$(MAKE) build
	cd $(BUILD) && ctest --output-on-failure --timeout 900

demo: deps
	$(MAKE) build
	./$(BUILD)/minimal

bench: deps
	$(MAKE) build
	@for b in $(BUILD)/bench_*; do [ -x "$$b" ] && { echo "== $$b"; "$$b"; }; done

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

clean:
	rm -rf $(BUILD)
