"""Maps and their frames: grids and map text, ROS robot maps in meters, configuration space."""
