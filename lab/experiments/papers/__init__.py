"""The papers `lab report PAPER` reproduces, each a module of its tables (tables.py says what a
table is)."""

from lab.experiments.papers.herzog import HERZOG
from lab.experiments.papers.hutter import HUTTER
from lab.experiments.papers.kim import KIM
from lab.experiments.papers.tables import Paper

PAPERS: dict[str, Paper] = {paper.name: paper for paper in (HUTTER, KIM, HERZOG)}
