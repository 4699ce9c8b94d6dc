"""Goal waves (whole-map and resumable), the decision and the paths it takes (the plan's walk,
the detour round dynamic obstacles), and ``plan()``."""
