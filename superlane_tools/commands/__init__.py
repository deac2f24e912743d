"""Thin orchestration, one unit per command (extract, reprocess, lanes, camera_estimate, batch).

Each command wires the layers below it (recordings, CAN, geometry, lane fit, scene, reporting)
into one run; commands never import each other, except ``batch``, which runs the others as jobs
(see ``docs/architecture.md``).
"""
