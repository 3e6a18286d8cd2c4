"""A human family, a reward rule and an agent added as docs/extending.md says, one file
each (the scenario is ``tests/scenario_box.py``): ``tests/test_extending.py`` registers them
and runs them through their conformance checks and a study."""
