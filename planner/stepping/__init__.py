"""Stepping a robot among dynamic obstacles: sessions, and whole simulated episodes."""
