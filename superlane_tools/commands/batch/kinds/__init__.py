"""Batch job kinds: what one batch job does to one recording, one module per kind."""
