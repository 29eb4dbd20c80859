"""Figures (matplotlib is imported only in this sub-package).

Plot functions take ``ax=None`` and return the Axes; they never call ``show()``.
"""
