"""People in the loop: recording sessions, playing in the terminal, serving a web page.

================  ====================================================================
module            contents
================  ====================================================================
``recording``     the human seat's recorder, and scripted humans' sessions recorded
``play``          ``hri-bench play``: you are the human, in the terminal
``serve``         ``hri-bench serve``: a person plays the human in a browser
``scene3d``       the MuJoCo scene as the page draws it in 3D
``synthetic``     scripted humans leading the arm through the page's protocol
``physical_fit``  a reference human fitted to recorded physical sessions
================  ====================================================================

It imports only the layers below :mod:`hri_bench.suite` (``lint-imports``).
"""
