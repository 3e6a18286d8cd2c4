"""The continuous envs' human: a whole arm on a torso, driven by their intention.

The arm and its friction grip (``whole_arm``; muscle-driven: ``muscles``), its size from sex,
stature and mass (``body``), the hand impedance and torque drive (``arm_control``), the route
and the intention conveyed by force with their parameters (``intention``), the same laws
compiled over a world axis (``laws``), families of humans (``families``), behavioural
signatures (``probe``) and the frozen train / validation / test populations
(``population``, made by ``population_build``; their data in ``data/``).
"""
