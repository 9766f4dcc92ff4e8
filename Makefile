# Convenience targets; each builds the virtual environment first if needed.
#   make lab           read and run the course in JupyterLab
#   make test          unit tests + every notebook under strict nbval
#   make notebooks     re-execute and save every notebook (after an edit)
#   make bench         benchmarks against filterpy (and particles, if its venv exists)
#   make student       write the student edition of every chapter into student/
#   make student-repo  write the repository to push for students into student-repo/ (one commit)
#   make instructor    add nbgrader (requirements-instructor.txt) to the environment
#   make guide         rewrite INSTRUCTORS.md's tables of exercises and rubrics from the notebooks
#   make lab-check     Run All of every chapter in JupyterLab in headless Chromium (needs chromium)
#   make site          build the course website into build/site/ (in its own .venv-site)
VENV ?= .venv
PYTHON ?= python3
BIN := $(VENV)/bin
# JupyterLab >= 4.4 with ipykernel 7 runs widget callbacks in a second kernel thread, where a
# slider's figure races the figures of "Run All" (INSTRUCTORS.md, "JupyterLab in class"): the
# course's environment switches that off.
LAB_SETTING := $(VENV)/share/jupyter/lab/settings/overrides.d/bayesfilt.json

$(BIN)/.installed: requirements.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/pip install -r requirements.txt
	mkdir -p $(dir $(LAB_SETTING))
	echo '{"@jupyterlab/apputils-extension:kernels-settings": {"commsOverSubshells": "disabled"}}' > $(LAB_SETTING)
	touch $@

.PHONY: lab test notebooks bench student student-repo instructor guide lab-check site
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

student-repo: $(BIN)/.installed
	$(BIN)/python tools/make_student_repo.py student-repo/ --git --force

instructor: $(BIN)/.installed
	$(BIN)/pip install -r requirements-instructor.txt

guide: $(BIN)/.installed
	$(BIN)/python tools/make_student_edition.py --update-guide

lab-check: $(BIN)/.installed
	$(BIN)/pip install --quiet -r requirements-site.txt
	$(BIN)/python tools/check_lab_browser.py

site:
	test -x .venv-site/bin/python || $(PYTHON) -m venv .venv-site
	.venv-site/bin/pip install --quiet -r requirements.txt -r requirements-site.txt
	.venv-site/bin/python tools/build_site.py
