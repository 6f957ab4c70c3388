"""What is seen of a part: its ground truth (`ground_truth`), the coverage of it
(`tracker`), the model-free occupancy grid (`occupancy`) and what a candidate
view would add through it (`view_gains`).
"""
