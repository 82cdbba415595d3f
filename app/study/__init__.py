"""The user study: questionnaires and their scoring, the study design, the analysis and its figures."""
