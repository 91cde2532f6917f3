# The two commands of the README. Each installs what is missing first (scripts/install-deps.sh).
.PHONY: deps test bench build clean device-kit

# Tests run on lavapipe with the validation layer; keep tests single-binary-parallel
# but not one Vulkan instance per core more than the machine has.
TEST_THREADS ?= 2
BENCH_OUT ?= bench-out

deps:
	@scripts/install-deps.sh

build: deps
	cargo build --release --locked

test: deps
	cargo test --locked -- --test-threads=$(TEST_THREADS)

# The overcast probe of the rnm study, when the shared assets are present.
OVERCAST ?= ../shared/assets/env/potsdamer_platz_1k.exr
# The real model of the normal-map study, when the shared assets are present.
MODEL ?= ../shared/assets/models/NormalTangentMirrorTest/NormalTangentMirrorTest.gltf
RNM_ENVS = sky:15$(if $(wildcard $(OVERCAST)),$(comma)$(OVERCAST))
NDF_ENVS = sky$(if $(wildcard $(OVERCAST)),$(comma)$(OVERCAST))
comma := ,
# Normal mapping for PRT against unc6 under the sun turned 90° after the bake.
NMPRT_ROWS = unc6,preconv,shlmap,nmprt,nmprtsvd4,nmprtsvd6,nmprthl2,nmprtratio

bench: build
	start=$$(date +%s); \
	target/release/shvis bench --out $(BENCH_OUT) && \
	target/release/shvis study rnm --envs $(RNM_ENVS) --out $(BENCH_OUT)/rnm && \
	target/release/shvis study normalmap $(if $(wildcard $(MODEL)),--model $(MODEL)) --out $(BENCH_OUT)/normalmap && \
	target/release/shvis study ndf --diffuse-envs $(NDF_ENVS) --out $(BENCH_OUT)/ndf && \
	target/release/shvis study nmprt-svd --out $(BENCH_OUT)/nmprt && \
	target/release/shvis bench --techniques $(NMPRT_ROWS) --relight-rotate 90 --point-reference --ref-spp 256 --no-probe --frames 3 --warmup 1 --out $(BENCH_OUT)/relit90 && \
	target/release/shvis bench --scene bumpy --techniques unc6,preconv,unc6ndf,preconvndf --specular mip,ndf,ndfn --light-dir 0,0.3,-1 --vis-res 256 --rays 256 --width 640 --height 360 --out $(BENCH_OUT)/specular && \
	echo "make bench: $$(( $$(date +%s) - start )) s after the build"

clean:
	cargo clean

# device-kit/: the release binary, the Vulkan loader's package and run.sh, for a bare
# machine with a Vulkan GPU (device-kit/run.sh OUT; docs/device-kit.md).
device-kit: deps
	scripts/device-kit/build.sh
