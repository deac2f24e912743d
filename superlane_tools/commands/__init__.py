"""Orchestration, one unit per ``slt`` command (``commands/<command>``), each with its entry.

``cli/<command>.py`` parses the options, calls the entry and prints its result; the command
wires the layers below it (recordings, CAN, geometry, lane fit, scene, reporting) into one run.
Commands never import each other, except ``batch``, which runs the others as jobs;
``options.py`` and ``errors.py`` serve them all (see ``docs/architecture.md``).
"""
