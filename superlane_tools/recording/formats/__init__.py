"""Each recording format's identity: magic numbers, suffixes, folder rule (spelled only here).

One module per format. They hold constants and pure tests on a :class:`~.probe.Probe`, import
nothing else of ``recording``, and are imported by the reader plug-in table
(:mod:`superlane_tools.recording.open`) and by the format's own reader, scanner and writer.
"""
