# make demo   — set up (first time) and show the dam mission compiled and verified
# make test   — set up (first time) and run the test suite
# make check  — lint (ruff) and type-check (mypy)
# make bench  — benchmarks (figures, not pass/fail)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test check bench clean install

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,dev]'
	touch $(STAMP)

demo: $(STAMP)
	@mkdir -p out
	$(BIN)/mclc missions/dam_inspection.mcl --dot out/dam_inspection.dot \
	    --dot-tasks out/dam_inspection.tasks.dot --pnml out/dam_inspection.pnml
	@echo
	@echo "== The dam mission on the simulated Ictineu (simulated time):"
	$(BIN)/mcl run missions/dam_inspection.mcl --log out/dam_inspection.jsonl --quiet
	@echo
	@echo "== Again, with a water leak 10 minutes in: the CATCH runs and the vehicle surfaces:"
	$(BIN)/mcl run missions/dam_inspection.mcl --inject leak@600 --log out/dam_leak.jsonl
	$(BIN)/mcl replay out/dam_leak.jsonl missions/dam_inspection.mcl
	@echo
	@echo "== Every mission in missions/:"
	$(BIN)/mclc missions/*.mcl | grep -E '^(missions|  (verified|NOT))'
	@echo
	@echo "Written to out/: run logs (*.jsonl), trajectory plots (*.svg), the nets (*.dot, *.pnml)"

test: $(STAMP)
	$(BIN)/python -m pytest -q

check: $(STAMP)
	$(BIN)/ruff check mcl petri behaviours vehicle vehicle_adapters tests bench
	$(BIN)/mypy mcl petri behaviours vehicle vehicle_adapters

bench: $(STAMP)
	$(BIN)/python bench/bench_verifier.py
	$(BIN)/python bench/bench_missions.py
	$(BIN)/python bench/bench_player.py
	$(BIN)/python bench/bench_vehicle.py
	$(BIN)/python bench/bench_zenoh.py
	$(BIN)/python bench/bench_mavlink.py

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
