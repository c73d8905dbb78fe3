# Quick start: `make demo` (set up, build, run the main job), `make test` (the whole suite).
# `make test-gui`: the walk through the artist's Blender in a real window (tests/gui);
# `make docs-gui`: the same walk, its screenshots copied into docs/images.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
VENV45 := .venv45
VENV52 := .venv52
# Blender 5.2 LTS's bpy needs Python 3.13: PY313, else a python3.13 on PATH, else the interpreter
# that PY313_SCRIPT prints (it builds and caches one); without any, the 5.2 leg is skipped.
PY313_SCRIPT ?= tools/python313.sh

.PHONY: demo test test52 test-gui docs-gui venv venv45 venv52 build lint clean

# $(call venv,FOLDER,PYTHON,EXTRA): a virtual environment with the project installed (editable),
# its development tools and the bpy of EXTRA.
define venv
$(1)/.installed: pyproject.toml
	$(2) -m venv $(1)
	$(1)/bin/pip install --quiet --upgrade pip
	$(1)/bin/pip install --quiet -e '.[dev,$(3)]'
	touch $$@
endef

venv: $(VENV)/.installed
venv45: $(VENV45)/.installed
venv52: $(VENV52)/.installed
$(eval $(call venv,$(VENV),$(PYTHON),blender50))
$(eval $(call venv,$(VENV45),$(PYTHON),blender45))
$(eval $(call venv,$(VENV52),$(PY313),blender52))

build: venv
	$(VENV)/bin/python tools/build_extension.py

demo: venv build
	$(VENV)/bin/python tools/demo.py

lint: venv
	$(VENV)/bin/ruff check .

# The review page's browser tests drive a Chromium (tools/chromium.sh finds or installs one).
test: venv venv45 build lint
	@chromium=$$(tools/chromium.sh) || echo "make test: the browser tests will be skipped: no Chromium"; \
	BO2_CHROMIUM="$$chromium" $(VENV)/bin/pytest tests/core tests/cli tests/blender tests/browser
	$(VENV45)/bin/pytest tests/blender
	@$(MAKE) --no-print-directory test52

# The Blender tests on 5.2 LTS (Python 3.13, numpy 2.3), the GPU backend's (the only bpy
# whose gpu module opens a context in background mode; required where EGL is found), and the
# share of tests/core that depends on the Python: the kernels, compiled by Python 3.13's
# numba, and the GPU backend's own (the rest is pure Python, run in the 5.0 leg).
CORE52 = tests/core/test_kernels.py tests/core/test_kernels_indirect.py \
         tests/core/test_kernels_shading.py tests/core/test_kernels_textures.py \
         tests/core/test_gpu_backend_imports.py tests/core/test_gpu_probe_cache.py

test52:
	@ok() { [ -n "$$1" ] && "$$1" -c 'import ssl, sys; assert sys.version_info[:2] == (3, 13)' >/dev/null 2>&1; }; \
	py="$(PY313)"; \
	ok "$$py" || py=$$(command -v python3.13); \
	ok "$$py" || py=$$([ -x "$(PY313_SCRIPT)" ] && $(PY313_SCRIPT)); \
	if ok "$$py"; then \
	  egl=$$( (ldconfig -p || /sbin/ldconfig -p) 2>/dev/null | grep -q 'libEGL.so.1 ' && echo 1); \
	  $(MAKE) --no-print-directory venv52 PY313="$$py" && \
	  BO2_REQUIRE_GPU=$$egl $(VENV52)/bin/pytest $(CORE52) tests/blender tests/gpu; \
	else \
	  echo "make test: skipped the Blender 5.2 LTS tests: no working Python 3.13 (PY313, python3.13 on PATH, $(PY313_SCRIPT))"; \
	fi

# The walk in Debian's windowed Blender 5.2 (Python 3.14), from the Linux zip as a user installs it.
test-gui: venv build
	$(VENV)/bin/python tests/gui/run.py dist/bo2_lighting-*-linux_x64.zip

docs-gui: venv build
	$(VENV)/bin/python tests/gui/run.py dist/bo2_lighting-*-linux_x64.zip --docs docs/images

clean:
	rm -rf dist out build wheels *.egg-info
