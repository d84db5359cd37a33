"""hcss.questionnaires."""
