# Streaming iELAS accelerator generator: the front door. `make help` lists targets and variables.
SHELL := /bin/bash
.DEFAULT_GOAL := help

CONFIG  ?= kitti
STAGE   ?= descriptor
SHARED  ?= ../shared/data
FRAMES  ?= 200
SEED    ?= 1
LEFT    ?=
RIGHT   ?=
GT      ?=
OUT     ?= build/simulate/$(notdir $(basename $(CONFIG)))-$(STAGE)
MODE    ?= ielas
PRESET  ?=
A       ?=
B       ?=
SWEEP   ?= quick

SBT      := ./sbt
SBT_RUN   = $(SBT) $(1) </dev/null
GOLDEN   := golden/build/ielas-golden
COMPARE  := golden/build/ielas-compare
SCALA_SRC  := $(shell find src/main/scala -name '*.scala' 2>/dev/null)
GOLDEN_SRC := $(shell find golden/src golden/include golden/tools golden/tests golden/CMakeLists.txt -type f 2>/dev/null)
CONFIG_NAME = $(notdir $(basename $(CONFIG)))
VERILOG_DIR = build/verilog/$(CONFIG_NAME)

.PHONY: help deps deps-sim deps-golden deps-synth configs golden golden-test verilog lint simulate compare run \
        test test-golden test-hw test-full soak bench eval synth sweep clean \
        sweep-configs sweep-point sweep-hwcheck test-sweep test-sim timing fusesoc-lint

help: ## this list
	@echo "Streaming iELAS stereo accelerator generator"
	@echo
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | sed -E 's/:.*## /\t/' | awk -F'\t' '{printf "  make %-10s %s\n", $$1, $$2}'
	@echo
	@echo "Variables: CONFIG=<name|file.json> (default kitti)  STAGE=descriptor|support|filter|interp|grid|..."
	@echo "           LEFT= RIGHT= GT= (a stereo pair, PNG/PGM)  OUT=<dir>  A= B= (dump dirs for compare)"
	@echo "           MODE=elas|ielas PRESET=robotics|middlebury (eval)  IELAS_SEED=<n> (replay a test seed)"
	@echo "           FRAMES=<n> SEED=<n> (soak)  SHARED=<dir> (the dataset folder, default ../shared/data)"

# ---- input preflight: scripts/check_inputs.py checks LEFT, RIGHT, GT, CONFIG and POINT in milliseconds (one line,
# exit 2). It is the first prerequisite of the targets that take them, and the installs that every long build waits
# for wait for it (order-only), so even `make -j` starts no build before it. PREFLIGHT: each target's arguments.
.PHONY: check-inputs
check-inputs: ## check LEFT, RIGHT, GT, CONFIG, POINT (images, sizes, names) without building anything
	@python3 scripts/check_inputs.py $(PREFLIGHT)
deps-sim deps-golden deps-synth: | check-inputs
run: PREFLIGHT = --config '$(CONFIG)' --left '$(LEFT)' --right '$(RIGHT)' --gt '$(GT)'
simulate: PREFLIGHT = --config '$(CONFIG)' --left '$(LEFT)' --right '$(RIGHT)' --require left,right
eval: PREFLIGHT = --config '$(if $(PRESET),,$(CONFIG))'
verilog lint fusesoc-lint synth soak: PREFLIGHT = --config '$(CONFIG)'
sweep-point: PREFLIGHT = --point '$(POINT)' --require point

# ---- installs (idempotent; skipped when present) ----
deps: deps-sim deps-golden ## install Verilator and OpenCV if missing (apt); sbt comes from ./sbt
deps-sim:
	@scripts/install-deps.sh verilator
deps-golden:
	@scripts/install-deps.sh opencv
deps-synth:
	@scripts/install-deps.sh yosys

# ---- parameters ----
configs: ## regenerate golden/configs/*.json and golden/configs/presets/*.json from ElasParams
	$(call SBT_RUN,"run configs golden/configs")

# ---- golden model ----
golden: $(GOLDEN) ## build ielas-golden (CMake + OpenCV; no sbt)
$(GOLDEN) $(COMPARE) &: $(GOLDEN_SRC) | deps-golden
	cmake -S golden -B golden/build -DCMAKE_BUILD_TYPE=Release >/dev/null
	cmake --build golden/build -j2

test-golden: golden ## golden unit tests (hand-computed cases), CLI error tests, input preflight tests
	ctest --test-dir golden/build --output-on-failure -j2
	IELAS_GOLDEN=$(abspath $(GOLDEN)) python3 scripts/test_check_inputs.py

# ---- hardware ----
verilog: check-inputs deps-sim ## SystemVerilog of IElas and IElasAxi in build/verilog/<config>/ + register map, FuseSoC core, memory summary
	$(call SBT_RUN,"run verilog $(CONFIG) $(VERILOG_DIR)")
	@$(MAKE) --no-print-directory lint CONFIG=$(CONFIG)

lint: check-inputs ## verilator --lint-only -Wall on build/verilog/<config>/*.sv (+ lint.vlt waivers)
	@test -n "$$(ls $(VERILOG_DIR)/*.sv 2>/dev/null)" || { echo "lint: no Verilog in $(VERILOG_DIR) (run make verilog CONFIG=$(CONFIG))"; exit 1; }
	verilator --lint-only -Wall $(wildcard $(VERILOG_DIR)/lint.vlt) $(VERILOG_DIR)/*.sv --top-module IElas
	@if [ -f $(VERILOG_DIR)/IElasAxi.sv ]; then \
	  echo "verilator --lint-only -Wall $(VERILOG_DIR)/lint.vlt $(VERILOG_DIR)/*.sv --top-module IElasAxi"; \
	  verilator --lint-only -Wall $(wildcard $(VERILOG_DIR)/lint.vlt) $(VERILOG_DIR)/*.sv --top-module IElasAxi; fi
	@echo "lint: clean ($(VERILOG_DIR))"

# FuseSoC from PyPI in a venv of its own; the core file is written by `make verilog` (IElasAxi.fusesocCore).
FUSESOC      := build/fusesoc-venv/bin/fusesoc
FUSESOC_CORE  = ielas:ip:ielas_axi_$(subst -,_,$(subst .,_,$(CONFIG_NAME)))
$(FUSESOC):
	scripts/install-deps.sh venv
	python3 -m venv build/fusesoc-venv
	build/fusesoc-venv/bin/pip install -q 'fusesoc>=2.3,<3'

fusesoc-lint: check-inputs deps-sim $(FUSESOC) ## FuseSoC runs the Verilator lint target of build/verilog/<config>/ielas_axi.core
	@test -f $(VERILOG_DIR)/ielas_axi.core || { echo "fusesoc-lint: no $(VERILOG_DIR)/ielas_axi.core (run make verilog CONFIG=$(CONFIG))"; exit 1; }
	rm -rf build/fusesoc/$(CONFIG_NAME) && mkdir -p build/fusesoc/$(CONFIG_NAME)
	cd build/fusesoc/$(CONFIG_NAME) && $(abspath $(FUSESOC)) --cores-root $(abspath $(VERILOG_DIR)) run --target lint $(FUSESOC_CORE)
	@echo "fusesoc-lint: clean ($(FUSESOC_CORE))"

simulate: check-inputs deps-sim ## Verilator model up to STAGE: writes STAGE's .npy files and cycles.txt to OUT
	@test -n "$(LEFT)" -a -n "$(RIGHT)" || { echo "simulate: set LEFT= and RIGHT="; exit 1; }
ifeq ($(STAGE),top)
	@$(MAKE) --no-print-directory verilog CONFIG=$(CONFIG)
	scripts/sim.sh run $(CONFIG) --left $(abspath $(LEFT)) --right $(abspath $(RIGHT)) --out $(abspath $(OUT))
else
	$(call SBT_RUN,"Test/runMain ielas.sim.Simulate --config $(CONFIG) --stage $(STAGE) --left $(abspath $(LEFT)) --right $(abspath $(RIGHT)) --out $(abspath $(OUT))")
endif

compare: $(COMPARE) ## compare every .npy in A= and B= (0 only if >= 1 file compared and all equal)
	@test -n "$(A)" -a -n "$(B)" || { echo "compare: set A= and B="; exit 1; }
	$(COMPARE) $(A) $(B)

run: check-inputs golden verilog ## the main job: Verilog for kitti, then a stereo pair through the hardware in Verilator
	scripts/sim.sh demo $(CONFIG) $(if $(LEFT),--left $(abspath $(LEFT))) $(if $(RIGHT),--right $(abspath $(RIGHT))) $(if $(GT),--gt $(abspath $(GT)))

# ---- tests ----
test: deps test-golden test-hw test-synth test-sim test-sweep ## everything CI runs (small configurations; < 60 min cold on 2 cores)
	@$(MAKE) --no-print-directory verilog CONFIG=small
	@$(MAKE) --no-print-directory fusesoc-lint CONFIG=small
	@$(MAKE) --no-print-directory verilog CONFIG=kitti
	@echo "make test: all passed"

test-sim: deps-sim golden
	IELAS_GOLDEN=$(abspath $(GOLDEN)) python3 scripts/test_sim.py

test-synth: deps-synth
	python3 scripts/synth/test_synth.py

test-hw: golden
	$(call SBT_RUN,test)

test-full: deps-sim golden ## full-size frames end to end (not in CI): KITTI 1241x376 and a 640x480 Reindeer crop
	scripts/test_full.sh

# The Verilog is build/verilog/<config>/ as `make verilog` left it (made only when missing).
soak: check-inputs deps-sim golden $(if $(wildcard $(VERILOG_DIR)/IElas.sv),,verilog) ## long robustness run (not in CI): FRAMES= (200) random-size frames, gaps, stalls, 1 in 10 malformed, vs golden; SEED=
	scripts/soak.sh $(CONFIG) --frames $(FRAMES) --seed $(SEED) --data $(SHARED)

# ---- measurements ----
eval: check-inputs golden ## accuracy tables: MODE=elas|ielas PRESET=robotics|middlebury or CONFIG=
	scripts/eval.sh $(MODE) $(if $(PRESET),--preset $(PRESET),--config $(CONFIG)) $(EVAL_ARGS)

bench: deps-sim golden ## cycles/pixel, latency, fps, simulator speed at kitti and tsukuba -> docs/performance.md
	scripts/bench.sh

synth: check-inputs deps-synth ## Yosys resource table for one configuration
	@$(MAKE) --no-print-directory verilog CONFIG=$(CONFIG)
	scripts/synth.sh $(CONFIG) $(VERILOG_DIR)

timing: CONFIG = small
# Modules that do not fit the LFE5U-85F at CONFIG, placed again where they do (CONFIG:MODULE,...): at a named
# configuration, or at one derived from a named one (TIMING_DERIVE, NAME:BASE:KEY=VALUE as `sbt "run config"` takes
# it; written to build/configs-extra/NAME.json). At small: the dense matcher also at small-c4 (at small it fills all
# 208 block RAMs; it did not fit when this was set up), the whole top at a 64x48
# small-w3 with cyclesPerPixel 8 (tiny-w3-c8, 78 % of the part's LUT4s; small needs more than the part has, and
# small-w3-c8 at 84 % did not route).
comma := ,
TIMING_DERIVE ?= $(if $(filter small,$(CONFIG)),tiny-w3-c8:small-w3:cyclesPerPixel=8$(comma)maxWidth=64$(comma)maxHeight=48)
# At small, the stages that fit the part at kitti are placed there too (the largest named configuration).
TIMING_KITTI := FrameGuard,Descriptor,SupportFilter,LatticeFill,GridVector,Planes,LrCheck,PostProcess,PostProcessSpeckle,PostRowGaps,PostColumnGaps,PostMean,PostMean_1,FrameSizeTable
TIMING_ALSO ?= $(if $(filter small,$(CONFIG)),small-c4:DenseMatcher tiny-w3-c8:IElas kitti:$(TIMING_KITTI))
timing: deps-synth ## ECP5 post-route fmax and 7-series logic-only STA per stage (CONFIG default small) -> docs/timing.md
	@$(MAKE) --no-print-directory verilog CONFIG=$(CONFIG)
	@for d in $(TIMING_DERIVE); do $(call SBT_RUN,"run config $(CURDIR)/build/configs-extra $$d") || exit 1; done
	@for c in $(foreach a,$(TIMING_ALSO),$(firstword $(subst :, ,$(a)))); do j=build/configs-extra/$$c.json; \
	  $(MAKE) --no-print-directory verilog CONFIG=$$(if [ -f $$j ]; then echo $(CURDIR)/$$j; else echo $$c; fi) || exit 1; done
	TIMING_ALSO='$(TIMING_ALSO)' scripts/timing/timing.sh $(CONFIG) $(VERILOG_DIR)

# ---- parameter sweep (docs/sweep.md; scripts/sweep.sh, scripts/sweep/) ----
# Each point is one target, so `make -j N sweep SWEEP=full` runs points in parallel (sbt steps take turns on a lock;
# each Yosys run has SYNTH_TIMEOUT and SYNTH_MEM_MB). The golden model is IELAS_GOLDEN when set, else `make golden`.
SWEEP_PY    := build/sweep-venv/bin/python
SWEEP_GRID   = $(if $(filter quick-%,$(POINT)),quick,full)
SWEEP_NEEDS  = deps-synth $(if $(IELAS_GOLDEN),,golden)

$(SWEEP_PY): # matplotlib for the plots, in a venv of its own (pip from PyPI)
	scripts/install-deps.sh venv
	python3 -m venv build/sweep-venv
	build/sweep-venv/bin/pip install -q 'matplotlib>=3.6,<4'

build/sweep/configs/.done: $(SCALA_SRC) scripts/sweep/grid.py
	scripts/sweep.sh configs full && touch $@
build/sweep-quick/configs/.done: $(SCALA_SRC) scripts/sweep/grid.py
	scripts/sweep.sh configs quick && touch $@

sweep-configs: build/sweep/configs/.done ## configuration JSONs of the full grid, from ElasParams (one sbt run)

sweep-point: check-inputs $(SWEEP_NEEDS) ## one sweep point, POINT=<name> (scripts/sweep/grid.py names full): a row of docs/sweep/results.csv
	@test -n "$(POINT)" || { echo "sweep-point: set POINT= (one of: $$(python3 scripts/sweep/grid.py names full | tr '\n' ' '))"; exit 1; }
	@$(MAKE) --no-print-directory build/sweep$(if $(filter quick,$(SWEEP_GRID)),-quick)/configs/.done
	python3 scripts/sweep/point.py $(POINT)

sweep-point-%: $(SWEEP_NEEDS) build/sweep/configs/.done
	python3 scripts/sweep/point.py $*

sweep: $(SWEEP_NEEDS) $(SWEEP_PY) ## the parameter sweep: SWEEP=quick (CI, build/sweep-quick/) or SWEEP=full (docs/sweep.md)
ifeq ($(SWEEP),quick)
	scripts/sweep.sh quick
else ifeq ($(SWEEP),full)
	@$(MAKE) --no-print-directory build/sweep/configs/.done
	@start=$$(date +%s); $(MAKE) --no-print-directory $(addprefix sweep-point-,$(shell python3 scripts/sweep/grid.py names full)); \
	  python3 scripts/sweep/agree.py --grid full || echo "sweep: WARNING: sum of modules and whole top disagree"; \
	  $(SWEEP_PY) scripts/sweep/report.py --grid full --wall $$(( $$(date +%s) - start )); \
	  python3 scripts/sweep/check.py --grid full
else
	@echo "sweep: SWEEP must be quick or full"; exit 2
endif

sweep-hwcheck: $(SWEEP_NEEDS) build/sweep/configs/.done ## full-size pairs through Verilator vs golden and the cycle model, 4 points
	python3 scripts/sweep/hwcheck.py $(if $(STAGE_HW),--stage $(STAGE_HW))

test-sweep: $(SWEEP_NEEDS) $(SWEEP_PY) # the sweep scripts' tests, then the quick sweep (for `make test`)
	python3 scripts/sweep/test_sweep.py
	$(MAKE) --no-print-directory sweep SWEEP=quick

clean: ## remove build outputs (keeps the sbt launcher cache)
	rm -rf golden/build target project/target test_run_dir $(filter-out build/sbt-launcher,$(wildcard build/*))
