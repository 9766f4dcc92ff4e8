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
sys.path.insert(0, str(ROOT / "tools"))
import build_site  # noqa: E402  (one definition of the Binder link)

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
    "sphinx_copybutton",        # a copy button on every code cell (not on outputs)
]

# The stored notebooks are rendered as they are: strict nbval proves their outputs current.
nb_execution_mode = "off"
nb_ipywidgets_js = {}           # no widget manager from a CDN (the notebooks store no widget state)
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 6
# A `$$` display glued to the line of text above it is still a display (as in JupyterLab),
# not inline maths: without this, MyST reads "text\n$$ a $$" as inline and the page shows
# stray `$` and raw TeX (tests/test_site.py checks that no page does).
myst_dmath_double_inline = True

exclude_patterns = ["student-notebooks/**", "_generated/**", "_snapshot/**", "_extra/**",
                    "**.ipynb_checkpoints"]
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
html_js_files = ["course.js"]   # search snippets from the article, file:// without fetch errors
html_favicon = "_static/favicon.svg"
html_extra_path = ["_extra"]    # notebooks/NN_*.ipynb (student edition) and the zip of them
# pydata-sphinx-theme reads the colour mode from here; left empty it logs
# "Got invalid theme mode" in the console of every page.
html_context = {"default_mode": "auto"}
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

# The copy button goes on code cells and code blocks, not on outputs (class "output").
copybutton_selector = 'div[class*="highlight-"]:not(.output) > div.highlight > pre'
copybutton_exclude = ".linenos, .gp, .go"
copybutton_prompt_text = r">>> |\.\.\. "
copybutton_prompt_is_regexp = True
copybutton_only_copy_prompt_lines = False

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


# --- a numbered multi-line display keeps its \tag --------------------------------------


def keep_tags_outside_split(app, doctree, docname):
    r"""Give MathJax a display that holds both a line break and a tag as written.

    Sphinx wraps every display that contains ``\\`` in ``\begin{split}...\end{split}``,
    where MathJax refuses ``\tag`` ("\tag not allowed in split environment"), although
    JupyterLab shows the same cell fine. Such a display is emitted unwrapped instead,
    inside MathJax's own display delimiters.
    """
    for node in doctree.findall(nodes.math_block):
        text = node.astext()
        if "\\tag" in text and "\\\\" in text and not node.get("nowrap"):
            node["nowrap"] = True
            node.children = [nodes.Text("\\[" + text + "\\]")]


# --- figures: a link to the full-size image (tap to zoom on a phone) -----------------------


def link_figures_to_full_size(app, doctree, docname):
    """Wrap every image of a chapter (not already in a link) in a link to the image file itself.

    The HTML builder copies an image to ``_images/<name>`` (``env.images``); the link points
    there, relative to the page. Sphinx does the same only for images given a width or scale.
    """
    if not docname.startswith("chapters/"):
        return
    from sphinx.util.osutil import relative_uri

    images_dir = relative_uri(app.builder.get_target_uri(docname), "_images")
    for image in list(doctree.findall(nodes.image)):
        if isinstance(image.parent, nodes.reference):
            continue
        uri = image["uri"]
        if uri not in app.env.images:
            continue
        target = f"{images_dir}/{app.env.images[uri][1]}"
        ref = nodes.reference("", "", internal=True, refuri=target,
                              classes=["figure-full-size"], reftitle="Open the full-size figure")
        image.replace_self(ref)
        ref.append(image)


# --- header buttons of a chapter: download the student notebook, launch it on Binder ------


def chapter_header_buttons(app, pagename, templatename, context, doctree):
    """Add the chapter's "download" and "launch" menus to the book theme's header buttons.

    Runs after the theme's own handlers (priority 502 > 501), which fill ``header_buttons``.
    The notebook offered is the student edition (``notebooks/<name>.ipynb`` of the site, copied
    there by tools/build_site.py); Binder opens the repository's notebook (with solutions).

    No Colab button: Colab opens a notebook alone, without the repository, so neither
    ``bayesfilt`` nor filterpy can be imported and the first code cell fails; it does not read
    ``requirements.txt``. Making it work would need a ``%pip install`` cell in every notebook.
    """
    if not pagename.startswith("chapters/") or "header_buttons" not in context:
        return
    name = pagename.split("/", 1)[1] + ".ipynb"
    pathto = context["pathto"]
    context["header_buttons"].insert(0, {
        "type": "group", "tooltip": "Download", "icon": "fas fa-download",
        "label": "download-buttons",
        "buttons": [
            {"type": "link", "url": pathto(f"notebooks/{name}", 1), "text": "Notebook (.ipynb)",
             "icon": "fas fa-code", "label": "download-notebook-button",
             "tooltip": "Download this chapter's notebook (student edition: the exercises are stubs)"},
            {"type": "link", "url": pathto("notebooks/bayesfilt-student-notebooks.zip", 1),
             "text": "All chapters (.zip)", "icon": "fas fa-file-zipper",
             "label": "download-all-button", "tooltip": "Every chapter's student notebook"},
            {"type": "javascript", "javascript": "window.print()", "text": "Print / PDF",
             "icon": "fas fa-file-pdf", "label": "download-pdf-button",
             "tooltip": "Print this chapter, or save it as PDF (the code lines wrap)"},
        ]})
    context["header_buttons"].insert(1, {
        "type": "group", "tooltip": "Launch", "icon": "fas fa-rocket", "label": "launch-buttons",
        "buttons": [
            {"type": "link", "url": build_site.binder_url(REPOSITORY, BRANCH, name), "text": "Binder",
             "icon": "_static/images/logo_binder.svg", "label": "binder-button",
             "tooltip": "Run this chapter on Binder (the repository's notebook, with solutions)"},
        ]})


def setup(app):
    app.connect("doctree-resolved", link_figures_to_full_size)
    app.connect("doctree-resolved", keep_tags_outside_split)
    app.connect("html-page-context", chapter_header_buttons, priority=502)
    app.connect("missing-reference", resolve_bf_alias)
    app.connect("missing-reference", external_as_code)
    app.connect("doctree-resolved", link_api_names)
