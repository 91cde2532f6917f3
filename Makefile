# The two commands of the README. Each installs what is missing first (scripts/install-deps.sh).
.PHONY: deps test bench bench-full build clean device-kit

# Tests run on lavapipe with the validation layer; keep tests single-binary-parallel
# but not one Vulkan instance per core more than the machine has. The `test-hooks` feature
# compiles the hooks the interruption and suspect-row tests drive (Cargo.toml).
TEST_THREADS ?= 2
BENCH_OUT ?= bench-out

deps:
	@scripts/install-deps.sh

build: deps
	cargo build --release --locked

test: deps
	cargo test --locked --features test-hooks -- --test-threads=$(TEST_THREADS)

# The overcast probe of the rnm study, when the shared assets are present.
OVERCAST ?= ../shared/assets/env/potsdamer_platz_1k.exr
# The real model of the normal-map study, when the shared assets are present.
MODEL ?= ../shared/assets/models/NormalTangentMirrorTest/NormalTangentMirrorTest.gltf
RNM_ENVS = sky:15$(if $(wildcard $(OVERCAST)),$(comma)$(OVERCAST))
NDF_ENVS = sky$(if $(wildcard $(OVERCAST)),$(comma)$(OVERCAST))
comma := ,
# The study of the lightmap bases: the built-in skies and every shared probe present.
PROBES = $(wildcard ../shared/assets/env/*_1k.exr)
empty :=
space := $(empty) $(empty)
BASES_ENVS = $(subst $(space),$(comma),$(strip sky sky:15 sky:60 $(PROBES)))
# The engine bases beside shlmap under the overcast probe (the default sky's rows are in
# the main bench).
ENGINE_SH_ROWS = shlmap,unc6,l1,l1geo,l1zh3,zh3,l1lum,shlmapw,hb4,hb6,sg6,sg9,sg12,dice,dicey,acube,acubels
# Normal mapping for PRT against unc6 under the sun turned 90° after the bake.
NMPRT_ROWS = unc6,preconv,shlmap,nmprt,nmprtsvd4,nmprtsvd6,nmprthl2,nmprtratio

# The main job: the paper's cost table and rows of each later family at 1280×800 with the
# references, errors, attribution ladder, figures and index.html (the bench prints its plan
# and estimate first, then the time left); dx11 rows for the headline's HEADLINE_DX11.
# Frames are few to fit five minutes on 2 cores.
bench: build
	target/release/shvis bench --techniques headline --paths dx9,dx10,dx11 --frames 9 --warmup 1 --probe-frames 5 --out $(BENCH_OUT)

# Everything: every row, every study, the relit and specular benches.
bench-full: build
	SHVIS=target/release/shvis OUT=$(BENCH_OUT) RNM_ENVS='$(RNM_ENVS)' NDF_ENVS='$(NDF_ENVS)' \
	MODEL_ARG='$(if $(wildcard $(MODEL)),--model $(MODEL))' NMPRT_ROWS='$(NMPRT_ROWS)' \
	BASES_ENVS='$(BASES_ENVS)' ENGINE_SH_ENV='$(if $(wildcard $(OVERCAST)),$(OVERCAST),sky:15)' \
	ENGINE_SH_ROWS='$(ENGINE_SH_ROWS)' \
	scripts/bench-full.sh

clean:
	cargo clean

# device-kit/: the release binary, the Vulkan loader's package and run.sh, for a bare
# machine with a Vulkan GPU (device-kit/run.sh OUT; docs/device-kit.md).
device-kit: deps
	scripts/device-kit/build.sh
