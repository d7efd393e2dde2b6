"""The label boxes of the docs' pictures (imported by docs/*/make.sh): a YOLO label file's
boxes (class, then centre and size as shares of the image) as pixel rectangles for Pillow's
`ImageDraw.rectangle`, `pad` pixels wider on every side so that a streak a few pixels long
stays visible inside its box."""


def label_rects(labels, w, h, pad):
    """The boxes of label file `labels` on a `w` x `h` image, in the file's order."""
    rects = []
    for line in open(labels):
        _, xc, yc, bw, bh = map(float, line.split())
        x0, y0 = (xc - bw / 2) * w - pad, (yc - bh / 2) * h - pad
        x1, y1 = (xc + bw / 2) * w + pad, (yc + bh / 2) * h + pad
        rects.append([x0, y0, x1, y1])
    return rects
