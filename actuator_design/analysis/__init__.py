"""Analyses over equilibria: each a function over results that re-solves one built NLP."""
