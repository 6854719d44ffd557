"""Whole-body control lab."""
