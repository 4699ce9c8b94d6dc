"""The map's analysis: cell states (gates, tight tunnels), the ``clean`` penalty, and a robot's
configuration space on a map in meters."""
