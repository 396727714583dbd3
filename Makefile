# Two commands set up and exercise a fresh machine:
#   make run   — build, and compare Halton, MDAS and pixel-adaptive Halton at
#                equal time on the default scene (Cornell box) against a
#                reference (out/)
#   make test  — the whole test suite (CPU Vulkan driver if there is no GPU)
# Both install a Vulkan driver first when none is present (.ci/ensure-vulkan.sh).
# `make help` lists every target.

CARGO ?= cargo
SCENE ?= scenes/cornell.toml
# `make run` writes no render at equal samples beside the comparison (it
# once rendered Halton and MDAS at the same 8 spp into out/, and before
# that Halton at 64 spp beside MDAS at 8): every image it writes, in
# out/compare-cornell, is at equal time.

.PHONY: run test lint crosscheck browser-test slurm-test vulkan build bench info clean clean-cache help mutants mutants-wgsl

vulkan:
	@./.ci/ensure-vulkan.sh

build: vulkan
	$(CARGO) build --release

info: build
	./target/release/mdas info

# The comparison runs at a quarter of the film with a 4,096-spp reference so
# that it takes minutes on a 2-core machine without a GPU; on a GPU use
# `mdas compare scenes/cornell.toml` (full film, 65,536-spp reference).
run: build
	./target/release/mdas info
	./target/release/mdas compare $(SCENE) --scale 0.25 --ref-spp 4096 --out out/compare-cornell
	@echo 'At equal time: out/compare-cornell/halton.png, mdas.png and adaptive.png (each method'"'"'s first seed),'
	@echo 'figure.png (the three side by side with their error maps), index.html (open it in a browser).'

# Formatting is checked first (seconds); clippy runs in CI after the tests
# (`.ci/run`: make test, then make lint), since a clean clippy build costs
# another ~4–6 minutes on 2 cores and `make test` must stay under 15
# minutes on 2 cores from a clean clone.
# The examples are built by `cargo test` (test profile, so `run --profile
# test` reuses them instead of compiling the crate again) and run after it,
# on small films (README, "Library").
test: vulkan
	$(CARGO) fmt --all -- --check
	$(CARGO) test --no-fail-fast
	$(CARGO) run --profile test --example custom_integrand -- target/examples-out/custom_integrand
	$(CARGO) run --profile test --example compare_scene -- scenes/cornell.toml target/examples-out/compare_scene 0.125 256
	$(CARGO) run --profile test --example light_sampler

bench: vulkan
	$(CARGO) bench

# Formatting and clippy on every target, warnings as errors; CI runs it
# after `make test`.
lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --all-targets -- -D warnings

# The independent renderer (issue 51): renders tests/crosscheck/scenes/*.xml
# with Mitsuba 3 (scalar_rgb, installed from the Python package registry
# into target/mitsuba-venv on first use) and with mdas (the test-profile
# binary `make test` built), and compares them statistically
# (tests/crosscheck/crosscheck.py). CI runs it after `make lint`.
crosscheck: vulkan
	$(CARGO) build --profile test --bin mdas
	MDAS=target/debug/mdas ./.ci/crosscheck.sh

# The comparison page in a real browser (issue 52): Debian's chromium
# (installed when missing) driven headless by playwright-core (pinned in
# tests/browser/package-lock.json) over the index.html of a small compare,
# sweep and tune and of a 1024×1024 comparison; screenshots checked against
# the EXRs and map PNGs, the console clean, the large page ready in < 2 s
# (.ci/browser-test.sh, docs/testing.md). CI runs it after `make crosscheck`.
browser-test: vulkan
	$(CARGO) build --profile test --bin mdas
	MDAS=target/debug/mdas ./.ci/browser-test.sh

# Opt-in (not in CI): a single-node Slurm cluster on this machine (Debian's
# slurm-wlm and munge, installed when missing) runs a 4-part reference as a
# job array with a dependent merge, checked against one process's
# (scripts/slurm/test.sh, docs/cluster.md).
slurm-test: vulkan
	./scripts/slurm/test.sh

# Mutation testing of the CPU code (`.ci/cargo-mutants.sh`): cargo-mutants
# on the samplers, trees, closed forms, metrics, comparison statistics and
# scene parsing, each module against its fast tests; ONLY="src/metrics/mod.rs" picks
# modules, LIST=1 only lists the mutants. Hours for all modules on 2 cores;
# not part of `make test`. docs/testing.md records the runs.
mutants: vulkan
	./.ci/cargo-mutants.sh

# WGSL mutation testing: plants estimator bugs (a dropped cosine, |cos|, a
# pdf in the wrong measure, a missing division by the pmf, a Morton bit off
# by one, a biased splat weight) in a copy of the kernels and requires the
# named tests to fail. Minutes per mutation; not part of `make test`.
mutants-wgsl: vulkan
	./.ci/wgsl-mutants.sh

# Build outputs (target/, which holds the Mitsuba venv and the examples'
# outputs too) and out/; the reference cache (.cache/references, the
# default --cache of every command) is kept: its renders take minutes to
# hours and are keyed by content, so they stay valid across builds.
clean:
	$(CARGO) clean
	rm -rf out

# The reference cache: every cached reference is rendered again on use.
clean-cache:
	rm -rf .cache/references

help:
	@echo 'make run           build, print the adapter, compare Halton, MDAS and pixel-adaptive Halton at equal time on $(SCENE) (out/)'
	@echo 'make test          rustfmt check, the whole test suite, then the examples'
	@echo 'make lint          rustfmt check and clippy on every target, warnings as errors'
	@echo 'make crosscheck    Mitsuba 3 and mdas render tests/crosscheck/scenes/*.xml; statistical comparison'
	@echo 'make browser-test  the comparison page driven in headless Chromium'
	@echo 'make slurm-test    a reference and a sweep as Slurm job arrays on a one-node cluster (opt-in)'
	@echo 'make mutants       cargo-mutants on the CPU code (hours; ONLY=..., LIST=1)'
	@echo 'make mutants-wgsl  plants estimator bugs in the WGSL kernels; the tests must catch each (ONLY=...)'
	@echo 'make bench         cargo bench (criterion)'
	@echo 'make build         release build (target/release/mdas)'
	@echo 'make info          the adapter, backend, features in use and limits'
	@echo 'make vulkan        install a Vulkan driver (Mesa) when none is present'
	@echo 'make clean         remove build outputs (target/) and out/; keeps the reference cache'
	@echo 'make clean-cache   remove the reference cache (.cache/references)'
	@echo 'make help          this list'
