"""Sphinx configuration of the course website (built by ``tools/build_site.py``).

Do not run Sphinx on this folder directly: ``tools/build_site.py`` first
stages it into ``build/site-src/`` together with the student edition of the
chapters, the notation page (from the README), the instructor's guide (from
INSTRUCTORS.md) and the generated API pages, then builds with warnings as
errors into ``build/site/``.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

from docutils import nodes

ROOT = Path(os.environ.get("BAYESFILT_ROOT", Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(ROOT))  # autodoc imports bayesfilt from the repository itself

REPOSITORY = os.environ.get("SITE_REPOSITORY", "OWNER/bayesfilt")  # GitHub owner/name
BRANCH = os.environ.get("SITE_BRANCH", "main")

project = "Bayesian filtering"
author = "the bayesfilt course authors"
copyright = "the bayesfilt course authors; code MIT, text and figures CC BY 4.0"
language = "en"

extensions = [
    "myst_nb",                  # notebooks and MyST markdown
    "sphinx.ext.autodoc",       # the bayesfilt reference, from the docstrings
    "numpydoc",                 # ... which are in numpydoc format
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",   # MathJax 3 served from _static/mathjax, no CDN
]

# The stored notebooks are rendered as they are: strict nbval proves their outputs current.
nb_execution_mode = "off"
nb_ipywidgets_js = {}           # no widget manager from a CDN (the notebooks store no widget state)
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 6

exclude_patterns = ["student-notebooks/**", "_generated/**", "_snapshot/**", "**.ipynb_checkpoints"]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb", ".rst": "restructuredtext"}

# Every unresolved cross-reference is an error (the build runs with -W). The docstrings may
# name numpy/scipy/filterpy objects, which are not documented here (no network, so no
nitpicky = True
# intersphinx): those render as code without a link (see ``external_as_code`` below).
EXTERNAL = re.compile(r"^(numpy|np|scipy|filterpy|matplotlib|mpl|plt)(\..*)?$"
                      r"|^(int|float|str|bool|tuple|list|dict|callable|None|optional|ndarray|array_like)$")

autodoc_member_order = "bysource"
autodoc_typehints = "none"       # the numpydoc Parameters sections give the types and shapes
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set = set()

html_theme = "sphinx_book_theme"
html_title = "Bayesian filtering"
html_static_path = ["_static"]
html_css_files = ["course.css"]
html_last_updated_fmt = None
html_copy_source = False
html_show_sourcelink = False
html_theme_options = {
    "repository_url": f"https://github.com/{REPOSITORY}",
    "repository_branch": BRANCH,
    "use_repository_button": True,
    "use_download_button": False,   # each chapter links its student-edition notebook instead
    "use_fullscreen_button": False,
    "show_toc_level": 2,
    "navigation_with_keys": False,
}

# MathJax 3: the notebooks write \boldsymbol etc.; every TeX package is loaded from the local copy.
mathjax3_config = {
    "tex": {"tags": "none"},
    "chtml": {"matchFontHeight": False},
}

# --- chapter pages link to the API pages where they name a function ----------------------

API_NAME = re.compile(r"^(?:bf|bayesfilt)\.(?P<path>[A-Za-z_][\w.]*?)(?:\(\s*\))?$")


def link_api_names(app, doctree, docname):
    """Turn inline code such as ``bf.kalman.update`` or ``bf.models.range_bearing()`` into a link.

    Only names that the API reference documents are linked; everything else stays as it is.
    """
    if not docname.startswith(("chapters/", "instructors", "index", "notation")):
        return
    objects = app.env.domains["py"].objects
    modules = app.env.domains["py"].modules
    for literal in list(doctree.findall(nodes.literal)):
        if isinstance(literal.parent, (nodes.reference, nodes.literal_block)):
            continue
        match = API_NAME.match(literal.astext().strip())
        if not match:
            continue
        full = "bayesfilt." + match.group("path")
        if full in objects:
            target_doc, anchor = objects[full].docname, objects[full].node_id
        elif full in modules:
            target_doc, anchor = modules[full].docname, modules[full].node_id
        else:
            continue
        uri = app.builder.get_relative_uri(docname, target_doc) + "#" + anchor
        ref = nodes.reference("", "", internal=True, refuri=uri, classes=["api-link"])
        literal.replace_self(ref)
        ref.append(literal)


def resolve_bf_alias(app, env, node, contnode):
    """Docstrings may write ``:func:`bf.kalman.update``` (the course's alias): resolve it as bayesfilt."""
    target = node.get("reftarget", "")
    if node.get("refdomain") != "py" or not target.startswith("bf."):
        return None
    node["reftarget"] = "bayesfilt." + target[3:]
    return env.domains["py"].resolve_xref(env, node["refdoc"], app.builder, node["reftype"],
                                          node["reftarget"], node, contnode)


def external_as_code(app, env, node, contnode):
    """A reference to numpy, scipy, matplotlib or filterpy: plain code, not a broken link."""
    if node.get("refdomain") != "py" or not EXTERNAL.match(node.get("reftarget", "")):
        return None
    contnode["classes"] = [c for c in contnode.get("classes", []) if c != "xref"] + ["external-name"]
    return contnode


def setup(app):
    app.connect("missing-reference", resolve_bf_alias)
    app.connect("missing-reference", external_as_code)
    app.connect("doctree-resolved", link_api_names)
