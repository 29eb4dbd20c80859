"""Parametric reduced-order models for updating, checked on the full model (docs/reduced-models.md)."""
