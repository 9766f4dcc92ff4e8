"""nbgrader's configuration for the bayesfilt course (nbgrader 0.9.6, requirements-instructor.txt).

Copy this file into your course folder and run nbgrader there (INSTRUCTORS.md,
"Grading with nbgrader", has the whole recipe; tests/test_nbgrader.py runs it):

    mkdir -p course/source/ch02
    cp nbgrader_config.py course/
    cp notebooks/02_kalman_derivation.ipynb course/source/ch02/
    cd course

The roster. nbgrader grades only the students it knows (``create_student`` is
off below, so a typo in a submission's folder name is an error, not a new
student). Import them once from a CSV file whose first line names the
columns; ``id`` is the folder name of each student's submission:

    id,first_name,last_name,email
    alice,Alice,Kim,alice@example.edu
    bob,Bob,Lee,bob@example.edu

    nbgrader db student import roster.csv

Due dates, one assignment per chapter (the assignment id is ``chNN``, the
notebook keeps its file name). Give the time zone: a submission's
``timestamp.txt`` is compared with it, and the export lists each submission's
lateness. A 14-week term (INSTRUCTORS.md, "A term") could use:

    nbgrader db assignment add ch01 --duedate="2027-03-14 23:59:00 +0900"
    nbgrader db assignment add ch02 --duedate="2027-03-28 23:59:00 +0900"
    nbgrader db assignment add ch03 --duedate="2027-04-11 23:59:00 +0900"
    nbgrader db assignment add ch04 --duedate="2027-04-25 23:59:00 +0900"
    nbgrader db assignment add ch05 --duedate="2027-05-09 23:59:00 +0900"
    nbgrader db assignment add ch06 --duedate="2027-05-23 23:59:00 +0900"
    nbgrader db assignment add ch07 --duedate="2027-06-06 23:59:00 +0900"
    nbgrader db assignment add ch08 --duedate="2027-06-13 23:59:00 +0900"
"""

c = get_config()  # noqa: F821 - nbgrader (traitlets) defines get_config when it reads this file

# The course. Its id names the course for nbgrader's exchange and formgrader.
c.CourseDirectory.course_id = "bayesfilt"

# The student's stub. nbgrader's default stub raises NotImplementedError, so Run All on the
# released notebook stopped at the first unanswered value cell and never ran the rest of the
# chapter (11-21 code cells, the optional sections included). This one does not raise: a
# function keeps its signature and docstring (they stand outside the markers in every chapter)
# and returns None, a value answer stays None (its line `name = None  # your answer` is outside
# the markers), and the check says "Not attempted yet". tools/make_student_edition.py uses the
# same stubs, so that the website, the student edition and the release read alike.
c.ClearSolutions.code_stub = {"python": "# YOUR CODE HERE"}
# The "why?" questions (markdown answer cells, graded by hand): the model answer and the rubric
# between the markers become this line; the question above them stays.
c.ClearSolutions.text_stub = "YOUR ANSWER HERE"

# Only the students of the roster are graded: a submission folder that is not a student id
# (a typo, a stray folder) stops `nbgrader autograde` with "No student with ID ... exists".
c.Autograde.create_student = False

# Lateness. nbgrader's usual setting, and this course's: no automatic penalty. A late
# submission is graded as usual, and `nbgrader export` lists its timestamp, the due date and
# the penalty (0), so that you apply your own policy. "zero" would give late work 0 points;
# a plugin of your own (a subclass of nbgrader.plugins.LateSubmissionPlugin, e.g. so much per
# day late) goes in c.AssignLatePenalties.plugin_class.
c.LateSubmissionPlugin.penalty_method = "none"

# nbgrader stops a cell that runs longer than this (seconds) and goes on with the next one. The
# checks stop a student's function after 10 s themselves (BAYESFILT_CHECK_TIME_LIMIT); this
# limit catches an answer cell that loops. Its message is what the graded notebook and the
# feedback page show under the stopped cell, instead of nbgrader's "No reply from kernel".
c.Execute.timeout = 30
c.Execute.error_on_timeout = {
    "ename": "TimeoutError",
    "evalue": "this cell did not finish within nbgrader's 30 s time limit and was stopped",
    "traceback": [
        "TimeoutError: this cell did not finish within nbgrader's 30 s time limit and was "
        "stopped (an endless loop?). Its answers keep the value they had before it ran "
        "(None), so the check below it says 'Not attempted yet'.",
    ],
}
