# make demo   — set up (first time) and show the dam mission compiled and verified
# make test   — set up (first time) and run the test suite, on every core (what CI runs)
# make test-quick — the edit-run loop: the suite without the tests marked slow, on every core
# make check  — lint (ruff), type-check (mypy), the missions, task libraries and examples in mcl fmt's layout
# make bench  — benchmarks (figures, not pass/fail)
# make vsix   — the VS Code extension (editors/vscode/): its grammars tested, then out/mcl.vsix
PYTHON ?= python3
PACKAGES := app mission mcl petri mosaic vehicle_adapters vehicle behaviours aal diagnostics
VENV   := .venv
BIN    := $(VENV)/bin
PIP_INSTALL := $(BIN)/python -m pip --disable-pip-version-check --quiet install
# Two installs, two stamps: the runtime (what `make demo` needs), then the test and development
# extras on top of it (what `make test`, `make check` and `make bench` need). Packages are
# byte-compiled at install: where PYTHONDONTWRITEBYTECODE is set nothing is cached at import,
# and every mclc would compile numpy and lark again (0.9 s instead of 0.5 s for the dam). The
# project's own packages too: an editable install does not compile them, and compiling the 60
# modules mclc loads would cost about 60 ms of every call (a bare Python takes 20 ms in all).
RUNTIME := $(VENV)/.installed-runtime
EXTRAS  := $(VENV)/.installed-extras

.PHONY: demo test test-quick check bench clean install install-all vscode-test vsix

install: $(RUNTIME)
install-all: $(EXTRAS)

$(RUNTIME): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(PIP_INSTALL) -e .
	$(BIN)/python -m compileall -q $(PACKAGES)
	touch $(RUNTIME)

# MAVProxy without its dependencies (pyproject.toml's test extra lists those a router needs):
# its own pull VTK, a second OpenCV and Shapely, 700 MB that the headless router never uses.
$(EXTRAS): $(RUNTIME)
	$(PIP_INSTALL) -e '.[test,dev]'
	$(PIP_INSTALL) --no-deps 'MAVProxy>=1.8'
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

# pytest-xdist: one worker more than the cores (a third of the suite's time is real-time waits
# and subprocesses: 2 cores ran it in 353 s with 3 workers, 431 s with 2), a test module at a
# time (--dist loadfile), so a module
# fixture (a dam run, a vehicle) is made once, not by each worker. (--dist loadgroup would
# send the rest test by test, but pytest 9.2 ignores the group xdist 3.8 tags a test with.)
# The modules in collection order, which tests/conftest.py makes longest first so that the
# workers end together (--no-loadscope-reorder: xdist's own order, most tests first, left the
# few long real-process files for the end, run by one worker while the other waited).
WORKERS ?= $(shell python3 -c 'import os; print((os.cpu_count() or 1) + 1)')
XDIST := -n $(WORKERS) --dist loadfile --no-loadscope-reorder

test: $(EXTRAS)
	$(BIN)/python -m pytest -q $(XDIST)

test-quick: $(EXTRAS)
	$(BIN)/python -m pytest -q $(XDIST) -m 'not slow'

check: $(EXTRAS)
	$(BIN)/ruff check $(PACKAGES) tests bench
	$(BIN)/mypy $(PACKAGES)
	$(BIN)/mcl fmt --check missions mcl/tasks examples

bench: $(EXTRAS)
	$(BIN)/python bench/bench_verifier.py
	$(BIN)/python bench/bench_scale.py
	$(BIN)/python bench/bench_mclc.py
	$(BIN)/python bench/bench_lsp.py
	$(BIN)/python bench/bench_timed.py
	$(BIN)/python bench/bench_fleet.py
	$(BIN)/python bench/bench_missions.py
	$(BIN)/python bench/bench_player.py
	$(BIN)/python bench/bench_vehicle.py
	$(BIN)/python bench/bench_mosaic.py
	$(BIN)/python bench/bench_dam_run.py
	$(BIN)/python bench/bench_fleet_run.py
	$(BIN)/python bench/bench_trackers.py
	$(BIN)/python bench/bench_uuv_navigator.py
	$(BIN)/python bench/bench_mcm.py
	$(BIN)/python bench/bench_zenoh.py
	$(BIN)/python bench/bench_mavlink.py

# The extension's Node packages (Node 20, npm): the pinned ones of package-lock.json, into
# editors/vscode/node_modules (not in git).
VSCODE := editors/vscode
$(VSCODE)/node_modules/.installed: $(VSCODE)/package.json $(VSCODE)/package-lock.json
	cd $(VSCODE) && npm ci --no-audit --no-fund
	touch $@

# The TextMate grammars against the parser's lexer on every shipped mission and task library.
vscode-test: $(RUNTIME) $(VSCODE)/node_modules/.installed
	rm -rf out/grammar-cases
	$(BIN)/python -m tests.editors.grammar_cases out/grammar-cases
	cd $(VSCODE) && npm test

vsix: vscode-test
	cd $(VSCODE) && npm run package

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis $(VSCODE)/node_modules
