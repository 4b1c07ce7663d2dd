"""Scenes: many trees under one wind, each at the level its camera distance allows (model.md 7)."""
