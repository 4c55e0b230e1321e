"""Importers from other linkage tools: pyslvs / PMKS expressions and projects, pylinkage JSON.

Each importer returns a raw linkage document (a dict in the form of ``specs/linkage.md``, links
given by length where the source gives lengths); :func:`linkedit.interop.convert.to_spec`
validates and assembles it.
"""
