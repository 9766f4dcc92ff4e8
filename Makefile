# Convenience targets; each builds the virtual environment first if needed.
#   make lab        read and run the course in JupyterLab
#   make test       unit tests + every notebook under strict nbval
#   make notebooks  re-execute and save every notebook (after an edit)
#   make bench      benchmarks against filterpy (and particles, if its venv exists)
#   make student    write the student edition of every chapter into student/
#   make site       build the course website into build/site/ (in its own .venv-site)
VENV ?= .venv
PYTHON ?= python3
BIN := $(VENV)/bin

$(BIN)/.installed: requirements.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/pip install -r requirements.txt
	touch $@

.PHONY: lab test notebooks bench student site
lab: $(BIN)/.installed
	$(BIN)/jupyter lab notebooks/

test: $(BIN)/.installed
	$(BIN)/pytest

notebooks: $(BIN)/.installed
	$(BIN)/python tools/run_notebooks.py

bench: $(BIN)/.installed
	$(BIN)/python benchmarks/bench_kalman.py
	$(BIN)/python benchmarks/bench_resampling.py
	$(BIN)/python benchmarks/bench_particle.py

student: $(BIN)/.installed
	$(BIN)/python tools/make_student_edition.py student/ --force

site:
	test -x .venv-site/bin/python || $(PYTHON) -m venv .venv-site
	.venv-site/bin/pip install --quiet -r requirements.txt -r requirements-site.txt
	.venv-site/bin/python tools/build_site.py
