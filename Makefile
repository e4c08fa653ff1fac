# flexgen: `make setup demo` sets up and runs the demo; `make test` runs the tests.
PYTHON ?= python3

.PHONY: setup lint test regen check-generated bench bench-kernels bench-growth bench-models bench-solver bench-chain bench-controller bench-sweep demo drawings

# Installs flexgen editable with its test and lint tools; builds the compiled core (flexgen._core)
# from flexgen/compiled and generated/c. Run it again after editing any C source.
setup:
	$(PYTHON) -m pip install --quiet -e ".[test,lint,plot]"

# ruff (lint and format check) and mypy, configured in pyproject.toml: zero findings expected
lint:
	$(PYTHON) -m ruff check .
	$(PYTHON) -m ruff format --check .
	$(PYTHON) -m mypy

# the suite on two worker processes (pytest-xdist): 4 to 7 minutes on 2 cores, 9 serially
test:
	$(PYTHON) -m pytest -q -n 2

# Rewrite generated/ and the generated finger controller on purpose (the golden tests compare
# them to a fresh generation; the controller embeds the solver core, so regenerate it after
# editing flexgen/compiled/chain_solver.c).
regen:
	$(PYTHON) -m flexgen generate --out generated
	@# changed kernels make the core stale: it is rebuilt before the controller is emitted from it
	$(PYTHON) -c "import flexgen" 2>/dev/null || $(MAKE) setup
	$(PYTHON) -m flexgen generate --scene examples/two_link_finger.toml --out examples/controller/two_link_finger

check-generated:
	$(PYTHON) -m flexgen generate --out generated --check
	$(PYTHON) -m flexgen generate --scene examples/two_link_finger.toml --out examples/controller/two_link_finger --check

# Every benchmark page under docs/ (about 9 minutes on 2 cores).
bench: bench-kernels bench-growth bench-models bench-solver bench-chain bench-controller

# flexgen bench (accuracy vs speed) and flexgen stability (where models fail) into docs/
# (flexgen_tools/bench.py, flexgen_tools/stability.py; need this checkout's examples/)
bench-models:
	OPENBLAS_NUM_THREADS=1 $(PYTHON) -m flexgen bench --out docs
	OPENBLAS_NUM_THREADS=1 $(PYTHON) -m flexgen stability --out docs

# time per solve: flexgen.solve, a prepared Solver.solve(), the bare core call; LAPACK vs built-in
bench-solver:
	OPENBLAS_NUM_THREADS=1 $(PYTHON) benchmarks/solver_speed.py --out docs/solver-speed.md

# time per solve of a chain of n = 1..32 flexures, and the evaluations per solve
bench-chain:
	OPENBLAS_NUM_THREADS=1 $(PYTHON) benchmarks/chain_scaling.py --out docs/chain-scaling.md

# wall time of design studies through flexgen.sweep (10^4 load cases, a 20 x 20 x 10 design grid);
# prints the table of docs/sweep.md, "Speed" (one run, about 15 s)
bench-sweep:
	OPENBLAS_NUM_THREADS=1 $(PYTHON) benchmarks/sweep.py

# time per solve of flexgen's controller against an expert's CasADi Newton solve (issue 9; needs
# casadi, the `bench` extra, installed here), the answers checked against flexgen.solve first
bench-controller:
	$(PYTHON) -m pip install --quiet "casadi>=3.6"
	OPENBLAS_NUM_THREADS=1 $(PYTHON) benchmarks/casadi_peer.py --out docs/controller-speed.md

bench-kernels:
	$(PYTHON) benchmarks/kernels.py --out docs/benchmarks.md

bench-growth:
	$(PYTHON) benchmarks/expression_growth.py --out docs/expression-growth.md

demo:
	$(PYTHON) examples/demo.py

# only the drawings of the demo, into docs/ (the demo itself draws into the untracked out/demo/;
# docs/finger.png, finger_slack.png, rectangular_elastica.png,
# arc_moment.png, cantilever_tip_load.png), as `flexgen plot` draws them
drawings:
	$(PYTHON) examples/demo.py --drawings
