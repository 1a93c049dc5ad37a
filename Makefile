# make demo   — set up (first time) and show the dam mission compiled and verified
# make test   — set up (first time) and run the test suite
# make check  — lint (ruff) and type-check (mypy)
# make bench  — benchmarks (figures, not pass/fail)
PYTHON ?= python3
PACKAGES := app mission mcl petri mosaic vehicle_adapters vehicle behaviours aal diagnostics
VENV   := .venv
BIN    := $(VENV)/bin
PIP_INSTALL := $(BIN)/python -m pip --disable-pip-version-check --quiet install
# Two installs, two stamps: the runtime (what `make demo` needs), then the test and development
# extras on top of it (what `make test`, `make check` and `make bench` need). Packages are
# byte-compiled at install: where PYTHONDONTWRITEBYTECODE is set nothing is cached at import,
# and every mclc would compile numpy and lark again (0.9 s instead of 0.5 s for the dam).
RUNTIME := $(VENV)/.installed-runtime
EXTRAS  := $(VENV)/.installed-extras

.PHONY: demo test check bench clean install install-all

install: $(RUNTIME)
install-all: $(EXTRAS)

$(RUNTIME): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(PIP_INSTALL) -e .
	touch $(RUNTIME)

$(EXTRAS): $(RUNTIME)
	$(PIP_INSTALL) -e '.[test,dev,large]'
	touch $(EXTRAS)

demo: $(RUNTIME)
	@mkdir -p out
	$(BIN)/mclc missions/dam_inspection.mcl --dot out/dam_inspection.dot \
	    --dot-tasks out/dam_inspection.tasks.dot --pnml out/dam_inspection.pnml
	@echo
	@echo "== The dam mission on the simulated Ictineu (simulated time):"
	$(BIN)/mcl run missions/dam_inspection.mcl --log out/dam_inspection.jsonl --quiet --no-images
	@echo
	@echo "== A short survey of the wall (3 m of it), ending with its photomosaic and coverage map:"
	$(BIN)/mcl run missions/dam_inspection.mcl --log out/dam_short.jsonl --quiet \
	    --param 'path=[(0, 1), (0, 4), (0.75, 4), (0.75, 1), (1.5, 1), (1.5, 4), (2.25, 4), (2.25, 1), (3, 1), (3, 4)]' \
	    --param 'recoveryPos=(-5, 1.5, 0.5, 0 deg)'
	@echo
	@echo "== Again, with a water leak 10 minutes in: the CATCH runs and the vehicle surfaces:"
	$(BIN)/mcl run missions/dam_inspection.mcl --inject leak@600 --log out/dam_leak.jsonl --no-images
	$(BIN)/mcl replay out/dam_leak.jsonl missions/dam_inspection.mcl
	@echo
	@echo "== Every mission in missions/:"
	$(BIN)/mclc missions/*.mcl | grep -E '^(missions|  (verified|NOT))'
	@echo
	@echo "Written to out/: run logs (*.jsonl), trajectory plots (*.svg), the mosaic and coverage map (*.mosaic.png, *.coverage.png), the nets (*.dot, *.pnml)"

test: $(EXTRAS)
	$(BIN)/python -m pytest -q

check: $(EXTRAS)
	$(BIN)/ruff check $(PACKAGES) tests bench
	$(BIN)/mypy $(PACKAGES)

bench: $(EXTRAS)
	$(BIN)/python bench/bench_verifier.py
	$(BIN)/python bench/bench_scale.py
	$(BIN)/python bench/bench_timed.py
	$(BIN)/python bench/bench_missions.py
	$(BIN)/python bench/bench_player.py
	$(BIN)/python bench/bench_vehicle.py
	$(BIN)/python bench/bench_mosaic.py
	$(BIN)/python bench/bench_dam_run.py
	$(BIN)/python bench/bench_trackers.py
	$(BIN)/python bench/bench_zenoh.py
	$(BIN)/python bench/bench_mavlink.py

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
