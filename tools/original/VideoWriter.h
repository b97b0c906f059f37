/*
 * Stand-in for the CRAFT simulator's VideoWriter.h, written from scratch for the
 * FFmpeg 5+ encoding API (avcodec_send_frame / avcodec_receive_packet).
 * tools/original/patch_sources.py copies it over the original header, which only
 * builds against FFmpeg 4.
 *
 * It offers what SimulationRenderer.cpp calls (init, videoFlush, deinit,
 * flipVertically) and keeps the encoder settings of the simulator: MPEG-1 video,
 * 4 Mb/s, 1/60 time base, GOP 25, at most one B-frame, yuv420p from RGB24,
 * written as a raw elementary stream closed by an MPEG sequence end code.
 *
 * SimulationRenderer.cpp includes this file inside an extern "C" block.
 */
#ifndef CRAFT_DSL_VIDEO_WRITER_FFMPEG5_H
#define CRAFT_DSL_VIDEO_WRITER_FFMPEG5_H

#ifdef __cplusplus
extern "C++" {
#include <string>
}
#endif

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <libavcodec/avcodec.h>
#include <libavutil/error.h>
#include <libavutil/frame.h>
#include <libavutil/pixfmt.h>
#include <libswscale/swscale.h>

typedef struct CraftVideoWriter {
    AVCodecContext *codec_ctx;
    AVFrame *yuv;
    AVPacket *packet;
    struct SwsContext *to_yuv;
    FILE *out;
    int64_t next_pts;
} CraftVideoWriter;

static CraftVideoWriter craft_video = { NULL, NULL, NULL, NULL, NULL, 0 };

static void craft_video_fail(const char *what, int err)
{
    char reason[AV_ERROR_MAX_STRING_SIZE] = "";
    if (err < 0)
        av_strerror(err, reason, sizeof reason);
    fprintf(stderr, "VideoWriter: %s%s%s\n", what, err < 0 ? ": " : "", reason);
    exit(1);
}

/* Write every packet the encoder has ready; returns once it needs more input or is drained. */
static void craft_video_write_ready_packets(void)
{
    for (;;) {
        int ret = avcodec_receive_packet(craft_video.codec_ctx, craft_video.packet);
        if (ret == AVERROR(EAGAIN) || ret == AVERROR_EOF)
            return;
        if (ret < 0)
            craft_video_fail("encoding failed", ret);
        if (fwrite(craft_video.packet->data, 1, (size_t)craft_video.packet->size, craft_video.out)
            != (size_t)craft_video.packet->size)
            craft_video_fail("short write to the video file", 0);
        av_packet_unref(craft_video.packet);
    }
}

/* Hand one frame (or NULL to flush) to the encoder, then write what comes out. */
static void craft_video_submit(const AVFrame *picture)
{
    int ret = avcodec_send_frame(craft_video.codec_ctx, picture);
    if (ret < 0)
        craft_video_fail("could not send a frame to the encoder", ret);
    craft_video_write_ready_packets();
}

/* Mirror an image top to bottom in place (glReadPixels returns the bottom row first). */
void flipVertically(unsigned char *buffer, const unsigned int width, const unsigned int height,
                    const int bytes_per_pixel)
{
    const size_t stride = (size_t)width * (size_t)bytes_per_pixel;
    unsigned char *spare = (unsigned char *)malloc(stride);
    unsigned int top = 0;
    unsigned int bottom = height;
    if (spare == NULL || height < 2) {
        free(spare);
        return;
    }
    while (top + 1 < bottom) {
        unsigned char *upper = buffer + (size_t)top * stride;
        unsigned char *lower = buffer + (size_t)(bottom - 1) * stride;
        memcpy(spare, upper, stride);
        memcpy(upper, lower, stride);
        memcpy(lower, spare, stride);
        ++top;
        --bottom;
    }
    free(spare);
}

/* Open the MPEG-1 encoder and the output file. */
static void init(const std::string &filePath, const int &width, const int &height)
{
    const AVCodec *codec = avcodec_find_encoder(AV_CODEC_ID_MPEG1VIDEO);
    int ret;
    if (codec == NULL)
        craft_video_fail("no MPEG-1 video encoder in this libavcodec", 0);

    craft_video.codec_ctx = avcodec_alloc_context3(codec);
    if (craft_video.codec_ctx == NULL)
        craft_video_fail("could not allocate the codec context", 0);
    craft_video.codec_ctx->bit_rate = 4000000;
    craft_video.codec_ctx->width = width;
    craft_video.codec_ctx->height = height;
    craft_video.codec_ctx->time_base.num = 1;
    craft_video.codec_ctx->time_base.den = 60;
    craft_video.codec_ctx->framerate.num = 60;
    craft_video.codec_ctx->framerate.den = 1;
    craft_video.codec_ctx->gop_size = 25;
    craft_video.codec_ctx->max_b_frames = 1;
    craft_video.codec_ctx->pix_fmt = AV_PIX_FMT_YUV420P;
    ret = avcodec_open2(craft_video.codec_ctx, codec, NULL);
    if (ret < 0)
        craft_video_fail("could not open the MPEG-1 encoder", ret);

    craft_video.out = fopen(filePath.c_str(), "wb");
    if (craft_video.out == NULL) {
        fprintf(stderr, "VideoWriter: could not open %s: %s\n", filePath.c_str(), strerror(errno));
        exit(1);
    }

    craft_video.yuv = av_frame_alloc();
    craft_video.packet = av_packet_alloc();
    if (craft_video.yuv == NULL || craft_video.packet == NULL)
        craft_video_fail("could not allocate a frame or a packet", 0);
    craft_video.yuv->format = AV_PIX_FMT_YUV420P;
    craft_video.yuv->width = width;
    craft_video.yuv->height = height;
    ret = av_frame_get_buffer(craft_video.yuv, 32);
    if (ret < 0)
        craft_video_fail("could not allocate the picture buffer", ret);

    /* SWS_BICUBIC is what swscale picks when no scaler flag is given. */
    craft_video.to_yuv = sws_getContext(width, height, AV_PIX_FMT_RGB24, width, height,
                                        AV_PIX_FMT_YUV420P, SWS_BICUBIC, NULL, NULL, NULL);
    if (craft_video.to_yuv == NULL)
        craft_video_fail("could not create the RGB to YUV converter", 0);
    craft_video.next_pts = 0;
}

/* Encode one RGB24 frame read back from GL (bottom row first). */
static void videoFlush(unsigned char *rgb, const int &width, const int &height)
{
    const uint8_t *const planes[1] = { rgb };
    const int strides[1] = { 3 * width };
    int ret;

    flipVertically(rgb, (unsigned int)width, (unsigned int)height, 3);

    /* The encoder may still hold the previous picture (B-frames): get a buffer of our own. */
    ret = av_frame_make_writable(craft_video.yuv);
    if (ret < 0)
        craft_video_fail("could not make the frame writable", ret);
    sws_scale(craft_video.to_yuv, planes, strides, 0, height, craft_video.yuv->data,
              craft_video.yuv->linesize);
    craft_video.yuv->pts = craft_video.next_pts++;
    craft_video_submit(craft_video.yuv);
}

/* Drain the encoder, close the stream with the MPEG end code and free everything. */
static void deinit(void)
{
    static const uint8_t sequence_end[4] = { 0x00, 0x00, 0x01, 0xb7 };
    if (craft_video.codec_ctx == NULL)
        return;
    craft_video_submit(NULL);
    fwrite(sequence_end, 1, sizeof sequence_end, craft_video.out);
    fclose(craft_video.out);
    craft_video.out = NULL;
    avcodec_free_context(&craft_video.codec_ctx);
    av_frame_free(&craft_video.yuv);
    av_packet_free(&craft_video.packet);
    sws_freeContext(craft_video.to_yuv);
    craft_video.to_yuv = NULL;
    craft_video.next_pts = 0;
}

#endif /* CRAFT_DSL_VIDEO_WRITER_FFMPEG5_H */
