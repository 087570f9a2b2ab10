"""Consumers of tick records: line output, the terminal live view, the browser view, pictures.

Every view takes records (:mod:`autonomy.record`) from a live run or a replay alike, and
never reaches into the runner, the client or the emulator.
"""
