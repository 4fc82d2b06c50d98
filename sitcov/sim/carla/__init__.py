"""sim/carla."""
