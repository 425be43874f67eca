package org.mcpt;

/** An engine error: the C API's status code and its message. */
public class RendererException extends RuntimeException {
    /** The mcpt_status code (negative), e.g. -4 for MCPT_ERROR_SCENE. */
    public final int status;

    public RendererException(int status, String message) {
        super(message);
        this.status = status;
    }
}
