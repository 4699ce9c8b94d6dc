"""The paper's experiment: its six environments (Table 1), and the seeded runs that compare
the presets."""
