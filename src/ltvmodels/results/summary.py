"""``Summary``: a report in sections, as plain text and as HTML tables.

A model's ``summary()`` (see :mod:`.model_summary` for what it says) returns a
:class:`Summary`. After statsmodels' ``iolib.summary.Summary``, it keeps its
content as data (sections of labelled fields and tables) and renders it twice:
:meth:`Summary.as_text` for the terminal and :meth:`Summary.as_html` for
notebooks (``_repr_html_``). It *is* the text, a ``str``: code written when
``summary()`` returned a string (``print``, ``in``, ``==``, ``startswith``,
``"\\n".join``) keeps working.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["Table", "Section", "Summary"]

WIDTH = 78
"""Width of the text report's rules (statsmodels' summaries are as wide)."""

LABEL_WIDTH = 20
"""Width of the labels of a section's fields in the text report."""


@dataclass(frozen=True)
class Table:
    """A table of text cells: a caption, a header row and rows of as many cells.

    Attributes
    ----------
    caption : str
        What the table shows (e.g. a segment and its time span).
    header : tuple of str, shape (columns,)
        The column titles; the first column is text (left-aligned in the text
        report), the others numbers (right-aligned).
    rows : tuple of tuple of str, shape (rows, columns)
        The cells, already formatted.
    """

    caption: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]

    def __post_init__(self) -> None:
        for row in self.rows:
            if len(row) != len(self.header):
                raise ValueError(
                    f"rows: expected {len(self.header)} cells per row (one per column of "
                    f"the header {list(self.header)}), received a row of {len(row)}"
                )


@dataclass(frozen=True)
class Section:
    """A titled part of a report: labelled fields, then tables.

    Attributes
    ----------
    title : str
        The section's title ("Data", "Model", …).
    fields : tuple of (str, str)
        (label, value) pairs, in order.
    tables : tuple of Table
        Tables after the fields (the coefficients).
    """

    title: str
    fields: tuple[tuple[str, str], ...] = ()
    tables: tuple[Table, ...] = ()


class Summary(str):
    """A report: a heading and sections, as plain text (the string itself) and as HTML.

    ``str(summary)``, ``print(summary)`` and ``repr(summary)`` give the text
    report (the repr is the text, not a quoted string, so that the report
    shows as a table at the prompt); notebooks show :meth:`as_html`.

    Parameters
    ----------
    heading : str
        The first line (a model's repr).
    sections : sequence of Section
        The parts of the report, in order.

    Attributes
    ----------
    heading : str
    sections : tuple of Section
    """

    # Not "title": that is a method of str.
    heading: str
    sections: tuple[Section, ...]

    def __new__(cls, heading: str, sections: Sequence[Section]) -> Summary:
        sections = tuple(sections)
        report = super().__new__(cls, _text(heading, sections))
        report.heading = heading
        report.sections = sections
        return report

    def __reduce__(self) -> tuple:
        # str's own reduction would call Summary(text): rebuild from the content instead.
        return (Summary, (self.heading, self.sections))

    def as_text(self) -> str:
        """The plain-text report (a plain ``str``)."""
        return str.__str__(self)

    def as_html(self) -> str:
        """The report as HTML: a ``<div>`` with one ``<table>`` per section and table."""
        parts = [
            '<div class="ltvmodels-summary">',
            f"<p><code>{html.escape(self.heading)}</code></p>",
        ]
        for section in self.sections:
            if section.fields:
                parts.append("<table>")
                parts.append(f"<caption>{html.escape(section.title)}</caption>")
                parts += [
                    f'<tr><th style="text-align:left">{html.escape(label)}</th>'
                    f'<td style="text-align:left">{html.escape(value)}</td></tr>'
                    for label, value in section.fields
                ]
                parts.append("</table>")
            for table in section.tables:
                parts.append(_html_table(section.title, table))
        parts.append("</div>")
        return "\n".join(parts)

    def _repr_html_(self) -> str:
        """What a notebook shows (IPython's rich display)."""
        return self.as_html()

    def __repr__(self) -> str:
        return self.as_text()


def _text(heading: str, sections: tuple[Section, ...]) -> str:
    lines = [heading, "=" * WIDTH]
    for section in sections:
        lines += [section.title, "-" * WIDTH]
        lines += [_field_line(label, value) for label, value in section.fields]
        for table in section.tables:
            lines += _table_lines(table)
    return "\n".join(lines)


def _field_line(label: str, value: str) -> str:
    # A label longer than its column gets one space before its value.
    return f"  {label:<{LABEL_WIDTH}} {value}".rstrip()


def _table_lines(table: Table) -> list[str]:
    widths = [
        max(len(cell) for cell in column) for column in zip(table.header, *table.rows, strict=True)
    ]

    def line(cells: tuple[str, ...]) -> str:
        first = f"{cells[0]:<{widths[0]}}"
        rest = [f"{cell:>{width}}" for cell, width in zip(cells[1:], widths[1:], strict=True)]
        return "    " + "  ".join([first, *rest])

    return [f"  {table.caption}", line(table.header), *map(line, table.rows)]


def _html_table(section: str, table: Table) -> str:
    cells = "".join(f"<th>{html.escape(cell)}</th>" for cell in table.header)
    rows = [
        "<tr>"
        + f'<td style="text-align:left">{html.escape(row[0])}</td>'
        + "".join(f"<td>{html.escape(cell)}</td>" for cell in row[1:])
        + "</tr>"
        for row in table.rows
    ]
    return "\n".join(
        [
            "<table>",
            f"<caption>{html.escape(section)}: {html.escape(table.caption)}</caption>",
            f"<thead><tr>{cells}</tr></thead>",
            "<tbody>",
            *rows,
            "</tbody>",
            "</table>",
        ]
    )
