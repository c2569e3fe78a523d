"""Analyses of a model or a fitted run that are neither sampling nor criticism.

- :mod:`.sensitivity`: reduced sensitivity coefficients and identifiability before sampling;
- :mod:`.urban`: the urban-scale comparison of the estimated h(t) with h = 4 + 4 v.
"""
