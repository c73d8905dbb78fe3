"""Comparisons with Cycles: metrics (``compare``, ``flip``), the pictures (``imaging``) and the
review page of many scenes (``report``, ``report_page``).
"""
