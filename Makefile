# Two commands set up and exercise a fresh machine:
#   make run   — build, render the default scene (Cornell box) and write out/
#   make test  — the whole test suite (CPU Vulkan driver if there is no GPU)
# Both install a Vulkan driver first when none is present (.ci/ensure-vulkan.sh).

CARGO ?= cargo
SCENE ?= scenes/cornell.toml
SPP ?= 64

.PHONY: run test vulkan build bench info clean

vulkan:
	@./.ci/ensure-vulkan.sh

build: vulkan
	$(CARGO) build --release

info: build
	./target/release/mdas info

run: build
	./target/release/mdas info
	./target/release/mdas render $(SCENE) --integrator halton --spp $(SPP) -o out/cornell-halton.exr

test: vulkan
	$(CARGO) test --no-fail-fast

bench: vulkan
	$(CARGO) bench

clean:
	$(CARGO) clean
	rm -rf out .cache
