"""The papers `lab report PAPER` reproduces, each a module of its tables (tables.py says what a
table is)."""

from lab.sweep.papers.herzog import HERZOG
from lab.sweep.papers.hutter import HUTTER
from lab.sweep.papers.kim import KIM
from lab.sweep.papers.tables import Paper

PAPERS: dict[str, Paper] = {paper.name: paper for paper in (HUTTER, KIM, HERZOG)}
