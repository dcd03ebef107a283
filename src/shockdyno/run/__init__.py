"""Sequencing: motion profiles, sweep plan, safety monitor, operator prompts, resume."""
