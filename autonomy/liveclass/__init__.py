"""A live class: students write, run and hand in missions from their browsers; the teacher watches.

:mod:`~autonomy.liveclass.store` keeps the class (SQLite, in the class's folder).
"""
