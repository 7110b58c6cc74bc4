//! A response body built whole in memory (a result download) that holds
//! its turn until it is sent: the bytes go out in [`PIECE`]-sized frames,
//! and the semaphore permit that let them be built is released only when
//! the last frame is taken or the client goes away (the body dropped). So
//! `--max-downloads` bounds the downloads held in memory, not only those
//! being built; a client that reads slowly keeps its own turn, and the
//! connection's timeouts bound how long.

use std::pin::Pin;
use std::task::{Context, Poll};

use axum::body::Bytes;
use hyper::body::{Body, Frame, SizeHint};
use tokio::sync::OwnedSemaphorePermit;

/// Bytes a frame carries: large enough that framing costs nothing, small
/// enough that the last piece in flight after the permit is gone is a
/// fraction of a download.
const PIECE: usize = 256 << 10;

/// `bytes`, sent in pieces, with `permit` held until the last is taken.
#[derive(Debug)]
pub struct HeldBody {
    bytes: Bytes,
    permit: Option<OwnedSemaphorePermit>,
}

impl HeldBody {
    pub fn new(bytes: Vec<u8>, permit: OwnedSemaphorePermit) -> Self {
        Self {
            bytes: Bytes::from(bytes),
            permit: Some(permit),
        }
    }
}

impl Body for HeldBody {
    type Data = Bytes;
    type Error = std::convert::Infallible;

    fn poll_frame(
        self: Pin<&mut Self>,
        _cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, Self::Error>>> {
        let this = self.get_mut();
        if this.bytes.is_empty() {
            this.permit = None;
            return Poll::Ready(None);
        }
        let piece = this.bytes.split_to(this.bytes.len().min(PIECE));
        if this.bytes.is_empty() {
            this.permit = None;
        }
        Poll::Ready(Some(Ok(Frame::data(piece))))
    }

    fn is_end_stream(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Exact, so the response carries `Content-Length`.
    fn size_hint(&self) -> SizeHint {
        SizeHint::with_exact(self.bytes.len() as u64)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use http_body_util::BodyExt;
    use tokio::sync::Semaphore;

    use super::*;

    #[tokio::test]
    async fn the_turn_is_held_until_the_last_piece_is_taken() {
        let turns = Arc::new(Semaphore::new(1));
        let len = 2 * PIECE + 7;
        let bytes: Vec<u8> = (0..len).map(|i| (i % 251) as u8).collect();
        let permit = Arc::clone(&turns).try_acquire_owned().expect("free");
        let mut body = HeldBody::new(bytes.clone(), permit);
        assert_eq!(body.size_hint().exact(), Some(len as u64));
        let mut got = Vec::new();
        for want in [PIECE, PIECE, 7] {
            assert_eq!(turns.available_permits(), 0, "held while pieces remain");
            let frame = body.frame().await.expect("a frame").expect("infallible");
            let piece = frame.into_data().expect("data");
            assert_eq!(piece.len(), want);
            got.extend_from_slice(&piece);
        }
        assert_eq!(turns.available_permits(), 1, "released with the last piece");
        assert!(body.is_end_stream());
        assert!(body.frame().await.is_none());
        assert_eq!(got, bytes);
    }

    #[tokio::test]
    async fn a_body_dropped_unsent_gives_its_turn_back() {
        let turns = Arc::new(Semaphore::new(1));
        let permit = Arc::clone(&turns).try_acquire_owned().expect("free");
        let body = HeldBody::new(vec![1; 3 * PIECE], permit);
        assert_eq!(turns.available_permits(), 0);
        drop(body);
        assert_eq!(turns.available_permits(), 1);
    }
}
