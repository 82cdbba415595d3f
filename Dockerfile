# cavewalk: a slim runtime image. The pose model is exported in a build stage, so
# torch and ultralytics never reach the final image (the runtime uses onnxruntime only).
#   docker build -t cavewalk .
#   docker run --rm -p 8000:8000 -p 8080:8080 -e CAVEWALK_SERVER__TOKEN=change-me cavewalk

# ---- stage 1: export yolo11n-pose to ONNX (needs torch + ultralytics, thrown away afterwards)
FROM python:3.11-slim AS models
WORKDIR /src
RUN apt-get update && apt-get install -y --no-install-recommends libgl1 libglib2.0-0 \
    && rm -rf /var/lib/apt/lists/*
COPY pyproject.toml README.md ./
COPY pipeline ./pipeline
COPY app ./app
COPY scripts/one_opencv.py ./scripts/one_opencv.py
# one_opencv.py: ultralytics pulls opencv-python next to opencv-python-headless; keep headless only
RUN pip install --no-cache-dir --extra-index-url https://download.pytorch.org/whl/cpu \
        torch torchvision \
    && pip install --no-cache-dir ".[models]" \
    && python scripts/one_opencv.py
ENV CAVEWALK_PATHS__MODELS_DIR=/models
RUN cavewalk models prepare

# ---- stage 2: the runtime
FROM python:3.11-slim AS runtime
WORKDIR /app
RUN useradd --create-home cavewalk
COPY pyproject.toml README.md alembic.ini ./
COPY pipeline ./pipeline
COPY app ./app
COPY migrations ./migrations
COPY frontend ./frontend
RUN pip install --no-cache-dir .
COPY --from=models /models /models
ENV CAVEWALK_PATHS__MODELS_DIR=/models \
    CAVEWALK_PATHS__DB=/data/cavewalk.db \
    CAVEWALK_PATHS__CACHE_DIR=/data/cache
RUN mkdir -p /data && chown cavewalk /data
VOLUME ["/data"]
USER cavewalk
EXPOSE 8000 8080
# Binding to 0.0.0.0 requires an operator token: set CAVEWALK_SERVER__TOKEN (or read the one printed at start).
CMD ["cavewalk", "serve", "--host", "0.0.0.0", "--port", "8000", "--viser-port", "8080"]
