#!/usr/bin/python3
# Draws sketch.png: the 64x64 8-bit greyscale sketch the sketched-island example starts from, as a
# level designer would paint it (dark sea, a grey island, a light mountain ridge and a bay).
# Run with Debian's Python (python3-pil): /usr/bin/python3 draw_sketch.py
from PIL import Image, ImageDraw, ImageFilter
import os
im = Image.new("L", (64, 64), 30)
d = ImageDraw.Draw(im)
d.ellipse((10, 12, 54, 52), fill=120)            # the island
d.ellipse((30, 36, 46, 56), fill=30)             # a bay cut into the south coast
d.line((18, 24, 30, 30, 44, 26), fill=230, width=5)  # the mountain ridge
d.ellipse((14, 40, 22, 46), fill=150)            # a hill in the south-west
im = im.filter(ImageFilter.GaussianBlur(2.0))
im.save(os.path.join(os.path.dirname(os.path.abspath(__file__)), "sketch.png"), optimize=True)
