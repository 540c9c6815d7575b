"""test_faults.py against the PostgreSQL backend: the same cases, each
server on a database of its own in a PostgreSQL started for this test
(tests/support/pgserver.py)."""
import os
import runpy

os.environ["INFILLD_TEST_BACKEND"] = "postgresql"
runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), "test_faults.py"),
               run_name="__main__")
