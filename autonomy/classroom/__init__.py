"""The classroom: exercises (what a mission should achieve), grading a class, and its reports.

from autonomy.classroom import load_exercise, find_submissions, grade_class
exercise = load_exercise("exercises/garage.yaml")    # raises ExerciseInvalid with every problem
reports = grade_class(exercise, find_submissions(["class/alice.yaml", "class/bob/"]))
"""

from autonomy.classroom.exercise import CRITERIA, Criterion, Exercise, ExerciseInvalid, Seed, load_exercise
from autonomy.classroom.grade import find_submissions, grade_class, grade_one
from autonomy.classroom.results import Report, SeedResult

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
    "grade_one",
    "load_exercise",
]
