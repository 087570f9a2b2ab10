"""The classroom: exercises (what a mission should achieve), grading a class, and its reports.

from autonomy.classroom import load_exercise, find_submissions, grade_class
exercise = load_exercise("exercises/garage.yaml")    # raises ExerciseInvalid with every problem
reports = grade_class(exercise, find_submissions(["class/alice.yaml", "class/bob/"]))
report = grade_mission(exercise, "alice", text, "alice.yaml", Path("."))   # one text, here
"""

from autonomy.classroom.criteria import CRITERIA
from autonomy.classroom.exercise import Criterion, Exercise, ExerciseInvalid, Seed, load_exercise
from autonomy.classroom.job import grade_mission, grade_one
from autonomy.classroom.pool import grade_class
from autonomy.classroom.results import Report, SeedResult
from autonomy.classroom.submissions import find_submissions

__all__ = [
    "CRITERIA",
    "Criterion",
    "Exercise",
    "ExerciseInvalid",
    "Report",
    "Seed",
    "SeedResult",
    "find_submissions",
    "grade_class",
    "grade_mission",
    "grade_one",
    "load_exercise",
]
