"""Math rendered at build time as MathML (no JavaScript, no CDN): the pages read the same offline.

docutils' own LaTeX → MathML converter (``docutils.utils.math.latex2mathml``, part of every
Sphinx install) turns each ``$…$``, ``$$…$$``, ``:math:`` and ``.. math::`` into a ``<math>``
element, which browsers lay out natively (MathML Core: Chromium ≥ 109, Firefox, Safari). A
formula the converter cannot read is a build warning naming the page, its line and the formula
(the docs build with ``-W``), never raw LaTeX on the page.
"""

import html
import re

from docutils import nodes
from docutils.utils.math import MathError
from docutils.utils.math.latex2mathml import tex2mathml
from sphinx.locale import _
from sphinx.util import logging
from sphinx.util.math import get_node_equation_number

logger = logging.getLogger(__name__)

# Unicode operators written in prose-style formulas (T − T_k, 4 × 10⁶) that the converter reads
# only as commands.
UNICODE_COMMANDS = {
    "−": "-", "×": r"\times ", "·": r"\cdot ", "≈": r"\approx ", "≤": r"\le ", "≥": r"\ge ",
    "±": r"\pm ", "→": r"\to ", "∞": r"\infty ", "∫": r"\int ", "′": "'", "°": r"{}^\circ ",
    "∝": r"\propto ", "≠": r"\ne ", "∂": r"\partial ", "√": r"\sqrt ",
}


def to_mathml(latex: str, block: bool, node: nodes.Element) -> str:
    """``<math>`` for a LaTeX formula, or the escaped formula with a warning naming it."""
    source = "".join(UNICODE_COMMANDS.get(c, c) for c in latex)
    if not block:  # inline math has no line breaks: `\\pi` is a `#:` comment's escaped `\pi`
        source = re.sub(r"\\\\(?=[A-Za-z])", r"\\", source)
    try:
        return tex2mathml(source, as_block=block)
    # The converter reports most bad input as MathError, some as a failure deep inside it.
    except (MathError, AttributeError, IndexError, KeyError, ValueError) as error:
        logger.warning("formula not converted to MathML (%s): %s", error, latex,
                       location=node, type="mathml")
        return f'<code class="math-error">{html.escape(latex)}</code>'


def visit_math(self, node: nodes.math) -> None:
    self.body.append(self.starttag(node, "span", "", CLASS="math notranslate nohighlight"))
    self.body.append(to_mathml(node.astext(), False, node))
    self.body.append("</span>")
    raise nodes.SkipNode


def visit_displaymath(self, node: nodes.math_block) -> None:
    self.body.append(self.starttag(node, "div", CLASS="math notranslate nohighlight"))
    if node["number"]:
        number = get_node_equation_number(self, node)
        self.body.append(f'<span class="eqno">({number})')
        self.add_permalink_ref(node, _("Link to this equation"))
        self.body.append("</span>")
    # Blank lines separate equations (as Sphinx's math directive); each is one block.
    for part in (p for p in node.astext().split("\n\n") if p.strip()):
        self.body.append(to_mathml(part.strip(), True, node))
    self.body.append("</div>\n")
    raise nodes.SkipNode


def setup(app):
    app.add_html_math_renderer("mathml", (visit_math, None), (visit_displaymath, None))
    app.add_css_file("mathml.css")
    return {"parallel_read_safe": True, "parallel_write_safe": True}
