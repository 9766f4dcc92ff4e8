/* The course's additions to the site's JavaScript (loaded on every page, before the search).

   1. Opened as files (file://), the browser refuses the requests that Sphinx's search makes
      to read each result page for its snippet ("Fetch API cannot load file://..."): there,
      the search lists the matching pages without snippets and makes no such request.
   2. Served over http, a snippet is taken from the page's article (not from the theme's
      header, breadcrumbs and buttons around it), with every equation as plain text instead
      of its TeX source.
*/
(function () {
  "use strict";
  // documentation_options.js declares `const DOCUMENTATION_OPTIONS`: a global binding, not a
  // property of window.
  if (window.location.protocol === "file:" && typeof DOCUMENTATION_OPTIONS !== "undefined") {
    DOCUMENTATION_OPTIONS.SHOW_SEARCH_SUMMARY = false;
  }

  const GREEK = {
    alpha: "α", beta: "β", gamma: "γ", delta: "δ", epsilon: "ε", varepsilon: "ε", zeta: "ζ",
    eta: "η", theta: "θ", kappa: "κ", lambda: "λ", mu: "μ", nu: "ν", xi: "ξ", pi: "π",
    rho: "ρ", sigma: "σ", tau: "τ", phi: "φ", varphi: "φ", chi: "χ", psi: "ψ", omega: "ω",
    Gamma: "Γ", Delta: "Δ", Theta: "Θ", Lambda: "Λ", Xi: "Ξ", Pi: "Π", Sigma: "Σ", Phi: "Φ",
    Psi: "Ψ", Omega: "Ω", ell: "ℓ", sum: "Σ", prod: "Π", top: "ᵀ", sim: "~", mid: "|",
    vert: "|", cdot: "·", times: "×", le: "≤", leq: "≤", ge: "≥", geq: "≥", approx: "≈",
    infty: "∞", to: "→", propto: "∝", int: "∫", partial: "∂", ne: "≠", neq: "≠",
  };

  /* TeX source as plain text: \Sigma -> Σ, \hat x -> x, x_{t|t} -> x_t|t, no braces. */
  function texToText(tex) {
    return tex
      .replace(/^\s*(\\\(|\\\[|\$\$?)/, "").replace(/(\\\)|\\\]|\$\$?)\s*$/, "")
      .replace(/\\(?:begin|end)\{[^}]*\}/g, " ")
      .replace(/\\([A-Za-z]+)/g, (m, name) => (name in GREEK ? GREEK[name] : " "))
      .replace(/\\[,;:! ]/g, " ").replace(/\\\\|&/g, " ")
      .replace(/[{}]/g, "")
      .replace(/\s+/g, " ").trim();
  }

  function articleText(htmlString, anchor) {
    const doc = new DOMParser().parseFromString(htmlString, "text/html");
    const drop = ".headerlink, script, style, .copybtn, .run-this-chapter, .beyond-sources-badge";
    doc.querySelectorAll(drop).forEach((el) => el.remove());
    doc.querySelectorAll("div.math, .math-wrapper").forEach((el) => el.replaceWith(" … "));
    doc.querySelectorAll("span.math, .math").forEach((el) => el.replaceWith(texToText(el.textContent)));
    const article = doc.querySelector("article.bd-article") || doc.querySelector('[role="main"]');
    if (!article) return "";
    let node = article;
    if (anchor) {
      try {
        node = article.querySelector(anchor) || article;
      } catch (e) {
        node = article;
      }
    }
    return node.textContent.replace(/\s+/g, " ").trim();
  }

  // searchtools.js (search page only) declares `const Search` at the top level: a global
  // binding, not a property of window. It is loaded after this file, before DOMContentLoaded.
  document.addEventListener("DOMContentLoaded", () => {
    if (typeof Search !== "undefined" && typeof Search.htmlToText === "function") {
      Search.htmlToText = articleText;
    }
  });
  window.bayesfiltTexToText = texToText;

  /* 3. An inline formula wider than its paragraph (a phone) scrolls inside its own box
        rather than making the whole page scroll sideways. */
  function markWideInlineMaths() {
    document.querySelectorAll(".bd-article mjx-container:not([display='true'])").forEach((el) => {
      el.classList.remove("wide-inline-math");
      const block = el.parentElement && el.parentElement.closest("p, li, dd, td, th, div");
      if (block && el.getBoundingClientRect().width > block.clientWidth + 1) {
        el.classList.add("wide-inline-math");
      }
    });
  }
  let resizeTimer = null;
  window.addEventListener("resize", () => {
    clearTimeout(resizeTimer);
    resizeTimer = setTimeout(markWideInlineMaths, 150);
  });
  window.addEventListener("load", () => {
    if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
      MathJax.startup.promise.then(markWideInlineMaths);
    }
  });
  window.bayesfiltMarkWideInlineMaths = markWideInlineMaths;
})();
